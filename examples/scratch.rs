use nalgebra::vector;
use reckon::methods::*;
use reckon::problems::*;
use reckon::*;
fn main() {
    for tol in [1e-10, 1e-11, 1e-12] {
        let y0 = arenstorf_y0();
        let s = Problem::new(arenstorf(), y0, (0.0, ARENSTORF_T)).solve(Dopri5::default(), &Options::default().rtol(tol).atol(tol)).unwrap();
        println!("aren tol={tol} e={:e} {:?}", (s.last().1 - y0).amax(), s.stats);
    }
    let x0 = vector![1.0, 0.5];
    for tol in [1e-3, 1e-4, 1e-5, 1e-6] {
        let s = Problem::new(rotation_decay(), x0, (0.0, 2.0)).solve(ImplicitEuler::default(), &Options::default().rtol(tol).atol(tol)).unwrap();
        println!("ie tol={tol} e={:e} {:?}", (s.last().1 - rotation_decay_exact(2.0, &x0)).amax(), s.stats);
    }
}

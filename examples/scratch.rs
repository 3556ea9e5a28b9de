use nalgebra::vector;
use reckon::methods::*;
use reckon::problems::*;
use reckon::*;
fn main() {
    let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 2000.0));
    for tol in [1e-3,1e-4,1e-5,1e-6] {
    let sol = p.solve(ImplicitEuler::default(), &Options::default().rtol(tol).atol(tol*1e-3)).unwrap();
    println!("{tol} {:?} {:?}", sol.last().1, sol.stats);
    }
    let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 3000.0));
    let opts = Options::default().rtol(1e-3).atol(1e-6);
    let ie = p.solve(ImplicitEuler::default(), &opts).unwrap();
    println!("{:?} {:?}", ie.last().1, ie.stats);
    let rk = p.solve(Dopri5::default(), &opts);
    match rk { Ok(rk) => println!("{:?} {:?} {:?}", rk.last().1, rk.stats, rk.stiffness), Err(e) => println!("{e}") }
}

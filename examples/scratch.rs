use nalgebra::vector;
use reckon::methods::*;
use reckon::models::unicycle;
use reckon::problems::*;
use reckon::*;
fn main() {
    let p = Problem::new(sin_u(), vector![0.5], (0.0, 5.0));
    let ex = sin_u_exact(5.0, 0.5);
    for k in 0..8 {
        let h = 1.0 / 2f64.powi(k);
        let s = p.solve(Dopri5::default(), &Options::default().fixed(h)).unwrap();
        println!("sin h={h} e={:e}", (s.last().1 - ex).amax());
    }
    let controls = Controls::new(
        vec![0.0, 1.0, 2.0, 3.0, 4.0],
        vec![vec![1.0, 0.8], vec![2.0, -0.5], vec![1.5, 0.0], vec![0.5, 2.0], vec![0.0, 0.0]],
    ).unwrap();
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.3], (0.0, 4.0)).controls(controls);
    let ex = *p.solve(Exact::new(unicycle::flow), &Options::default()).unwrap().last().1;
    for k in 0..8 {
        let h = 0.3 / 2f64.powi(k);
        let s = p.solve(Dopri5::default(), &Options::default().fixed(h)).unwrap();
        println!("uni h={h} e={:e}", (s.last().1 - ex).amax());
    }
}

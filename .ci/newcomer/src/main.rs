//! The README's Quick start, with reckon as the only dependency.
use reckon::prelude::*;

fn main() {
    // Van der Pol, μ = 1: y1' = y2, y2' = μ(1 − y1²)y2 − y1
    let vdp = model!(|_t, y: [S; 2]| vector![y[1], (1.0 - y[0] * y[0]) * y[1] - y[0]]);
    let problem = Problem::new(&vdp, vector![2.0, 0.0], (0.0, 20.0));
    let rk = problem.solve(Rk45, &Options::default().rtol(1e-8).atol(1e-8)).unwrap();
    let ie = problem.solve(ImplicitEuler::default(), &Options::default().fixed(1e-3)).unwrap();
    let (t, y) = rk.last();
    assert_eq!(t, 20.0);
    assert!((ie.last().1 - y).amax() < 0.1);
    let drag = model!(|_t, x: [S; 1]| vector![-x[0] * x[0].abs()]);
    assert_eq!(dvector![1.0, 2.0].len(), 2);
    let d = Problem::new(&drag, vector![1.0], (0.0, 1.0))
        .solve(Rk45, &Options::default().rtol(1e-10).atol(1e-12))
        .unwrap();
    assert!((d.last().1[0] - 0.5).abs() < 1e-9); // x' = −x², x(1) = 1/2
    let m: Matrix2<f64> = matrix![0.0, 1.0; -1.0, 0.0];
    println!("newcomer ok: y(20) = {y}, m·y = {}", m * y);
}

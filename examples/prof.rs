#[path = "../benches/handwritten.rs"]
mod handwritten;
use reckon::methods::*;
use reckon::problems::*;
use reckon::*;
use std::hint::black_box;
fn main() {
    let which = std::env::args().nth(1).unwrap();
    let tol = 1e-8;
    let opts = Options::default().rtol(tol).atol(tol).dense(false);
    let v = van_der_pol(1.0);
    let pv = Problem::new(&v, nalgebra::vector![2.0, 0.0], (0.0, 20.0));
    for _ in 0..200 {
        if which == "vr" {
            black_box(pv.solve(Dopri5::default(), black_box(&opts)).unwrap().stats.accepted);
        } else {
            black_box(handwritten::dopri5(handwritten::van_der_pol, 0.0, 20.0, black_box([2.0, 0.0]), tol).accepted);
        }
    }
}

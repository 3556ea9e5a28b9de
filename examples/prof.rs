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
    let a = arenstorf();
    let p = Problem::new(&a, arenstorf_y0(), (0.0, ARENSTORF_T));
    for _ in 0..200 {
        if which == "r" {
            black_box(p.solve(Dopri5::default(), black_box(&opts)).unwrap().stats.accepted);
        } else {
            black_box(
                handwritten::dopri5(handwritten::arenstorf, 0.0, ARENSTORF_T, black_box(ARENSTORF_Y0), tol).accepted,
            );
        }
    }
}

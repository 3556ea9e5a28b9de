#[path = "../benches/handwritten.rs"]
mod handwritten;
use reckon::methods::*;
use reckon::problems::*;
use reckon::*;
use std::hint::black_box;
use std::time::Instant;
fn time<R>(n: usize, mut f: impl FnMut() -> R) -> f64 {
    for _ in 0..n / 5 {
        black_box(f());
    }
    let t = Instant::now();
    for _ in 0..n {
        black_box(f());
    }
    t.elapsed().as_secs_f64() / n as f64 * 1e6
}
fn main() {
    for tol in [1e-4, 1e-8] {
        let opts = Options::default().rtol(tol).atol(tol).dense(false);
        let a = arenstorf();
        let p = Problem::new(&a, arenstorf_y0(), (0.0, ARENSTORF_T));
        let r = time(2000, || {
            p.solve(Dopri5::default(), black_box(&opts)).unwrap().stats.accepted
        });
        let h = time(2000, || {
            handwritten::dopri5(handwritten::arenstorf, 0.0, ARENSTORF_T, black_box(ARENSTORF_Y0), tol).accepted
        });
        println!("arenstorf {tol:e} ratio {:.3}", r / h);
        let l = lorenz();
        let p = Problem::new(&l, lorenz_y0(), (0.0, 20.0));
        let r = time(1000, || {
            p.solve(Dopri5::default(), black_box(&opts)).unwrap().stats.accepted
        });
        let h = time(1000, || {
            handwritten::dopri5(handwritten::lorenz, 0.0, 20.0, black_box([1.0, 1.0, 1.0]), tol).accepted
        });
        println!("lorenz {tol:e} ratio {:.3}", r / h);
        let v = van_der_pol(1.0);
        let p = Problem::new(&v, nalgebra::vector![2.0, 0.0], (0.0, 20.0));
        let r = time(5000, || {
            p.solve(Dopri5::default(), black_box(&opts)).unwrap().stats.accepted
        });
        let h = time(5000, || {
            handwritten::dopri5(handwritten::van_der_pol, 0.0, 20.0, black_box([2.0, 0.0]), tol).accepted
        });
        println!("vdp {tol:e} ratio {:.3}", r / h);
    }
}

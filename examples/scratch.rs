#[path = "../benches/handwritten.rs"]
mod handwritten;
use reckon::methods::*;
use reckon::problems::*;
use reckon::*;
use std::hint::black_box;
use std::time::Instant;
fn time<R>(name: &str, n: usize, mut f: impl FnMut() -> R) -> f64 {
    for _ in 0..n / 10 {
        black_box(f());
    }
    let t = Instant::now();
    for _ in 0..n {
        black_box(f());
    }
    let dt = t.elapsed().as_secs_f64() / n as f64 * 1e6;
    println!("{name}: {dt:.2} us");
    dt
}
fn main() {
    micro();
    let tol = 1e-8;
    let opts = Options::default().rtol(tol).atol(tol).dense(false);
    let a = arenstorf();
    let p = Problem::new(&a, arenstorf_y0(), (0.0, ARENSTORF_T));
    let r = time("reckon arenstorf", 2000, || {
        p.solve(Dopri5::default(), black_box(&opts)).unwrap().stats.accepted
    });
    let h = time("hand arenstorf", 2000, || {
        handwritten::dopri5(handwritten::arenstorf, 0.0, ARENSTORF_T, black_box(ARENSTORF_Y0), tol).accepted
    });
    println!("ratio {:.3}", r / h);
    let l = lorenz();
    let p = Problem::new(&l, lorenz_y0(), (0.0, 20.0));
    let r = time("reckon lorenz", 1000, || {
        p.solve(Dopri5::default(), black_box(&opts)).unwrap().stats.accepted
    });
    let h = time("hand lorenz", 1000, || {
        handwritten::dopri5(handwritten::lorenz, 0.0, 20.0, black_box([1.0, 1.0, 1.0]), tol).accepted
    });
    println!("ratio {:.3}", r / h);
}
#[allow(dead_code)]
fn micro() {
    let a = arenstorf();
    let mut dx = nalgebra::Vector4::zeros();
    let mut x = arenstorf_y0();
    let r = time("reckon rhs x1000", 2000, || {
        for _ in 0..1000 {
            a.rhs(0.0, black_box(&x), &[], &mut dx);
            x[3] += dx[0] * 1e-30;
        }
        dx[2]
    });
    let mut y = ARENSTORF_Y0;
    let h = time("hand rhs x1000", 2000, || {
        let mut d = [0.0; 4];
        for _ in 0..1000 {
            d = handwritten::arenstorf(0.0, black_box(&y));
            y[3] += d[0] * 1e-30;
        }
        d[2]
    });
    println!("ratio {:.3}", r / h);
}

//! Time and memory of tracing and compiling the 1-D Brusselator's Jacobian at growing sizes:
//! `cargo run --release --example trace_scaling -- 500000` (grid points; 2N states).

#[path = "common/rss.rs"]
mod rss;
use reckon::jacobian::SparseJacobian;
use reckon::studies::problems::brusselator;
use reckon::symbolic;
use rss::peak_rss_mib;
use std::time::Instant;

fn main() {
    let n: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(10_000);
    let f = brusselator(n);
    let t0 = Instant::now();
    let tr = symbolic::trace(&f, 2 * n).unwrap();
    let t1 = Instant::now();
    let mut jac = tr.compile_jacobian();
    let t2 = Instant::now();
    let nodes = tr.nodes();
    drop(tr);
    let x = reckon::studies::problems::brusselator_y0(n);
    let mut v = vec![0.0; jac.pattern().nnz()];
    let t3 = Instant::now();
    jac.eval(0.0, x.as_slice(), &[], &mut v).unwrap();
    let t4 = Instant::now();
    println!(
        "N = {n} ({} states): trace {:.3} s ({nodes} nodes), compile {:.3} s ({} instructions), one evaluation {:.3} ms ({} non-zeros), peak RSS {:.0} MiB",
        2 * n,
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        jac.instructions(),
        (t4 - t3).as_secs_f64() * 1e3,
        v.len(),
        peak_rss_mib()
    );
}

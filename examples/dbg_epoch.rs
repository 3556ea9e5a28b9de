use reckon::methods::{Bdf, Dopri5, Exact, Rodas5P};
use reckon::models::unicycle;
use reckon::{Controls, Options, Problem};
fn main() {
    let n = 200;
    for t0 in [0.0, 1.7e9, 1e15] {
        let times: Vec<f64> = (0..=n).map(|k| t0 + k as f64).collect();
        let values: Vec<Vec<f64>> = (0..=n)
            .map(|k| vec![1.0 + 0.3 * (k as f64 * 0.37).sin(), 0.5 * (k as f64 * 0.21).cos()])
            .collect();
        let c = Controls::new(times, values).unwrap();
        let p = Problem::new(unicycle::model(), nalgebra::vector![0.0, 0.0, 0.0], (t0, t0 + n as f64)).controls(c);
        let o = Options::default();
        let ex = p.solve(Exact::new(unicycle::flow), &o).unwrap();
        let e = ex.last().1;
        let b = p.solve(Bdf::default(), &o).unwrap();
        let r = p.solve(Rodas5P::default(), &o).unwrap();
        let d = p.solve(Dopri5::default(), &o).unwrap();
        println!(
            "t0 {t0:e}: bdf {:.3e} rodas {:.3e} rk45 {:.3e} bdf steps {}",
            (b.last().1 - e).amax(),
            (r.last().1 - e).amax(),
            (d.last().1 - e).amax(),
            b.stats.accepted
        );
    }
}

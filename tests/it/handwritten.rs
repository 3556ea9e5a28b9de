//! reckon's RK45 does the same work as a minimal hand-written Dormand–Prince loop with
//! the same controller: equal rhs counts (±2%) and equal answers.

#[path = "../../benches/handwritten.rs"]
mod hand;

use reckon::methods::Rk45;
use reckon::studies::problems::*;
use reckon::{Options, Problem, System};

fn compare<const N: usize>(
    name: &str,
    sys: impl System<nalgebra::Const<N>>,
    hand: fn(f64, &[f64; N]) -> [f64; N],
    x0: [f64; N],
    t_end: f64,
) {
    for tol in [1e-4, 1e-6, 1e-8, 1e-10] {
        let h = hand::dopri5(hand, 0.0, t_end, x0, tol);
        let p = Problem::new(&sys, nalgebra::SVector::from(x0), (0.0, t_end));
        let r = p
            .solve(Rk45, &Options::default().rtol(tol).atol(tol).dense(false))
            .unwrap();
        let ratio = r.stats.rhs_evals as f64 / h.evals as f64;
        assert!(
            (ratio - 1.0).abs() <= 0.02,
            "{name} tol {tol}: reckon {} evals, hand-written {}",
            r.stats.rhs_evals,
            h.evals
        );
        assert_eq!(r.last().0, t_end);
        let hx = h.x.last().unwrap();
        let scale = hx.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        // chaotic Lorenz amplifies rounding differences; the others agree closely
        let agree = if name == "lorenz" { 1.0 } else { 1e3 * tol };
        for (i, hxi) in hx.iter().enumerate() {
            assert!(
                (r.last().1[i] - hxi).abs() <= agree * scale,
                "{name} tol {tol}: component {i}"
            );
        }
    }
}

#[test]
fn same_work_as_the_hand_written_loop() {
    compare("lorenz", lorenz(), hand::lorenz, [1.0, 1.0, 1.0], 20.0);
    compare("arenstorf", arenstorf(), hand::arenstorf, ARENSTORF_Y0, ARENSTORF_T);
    compare("vdp", hand::van_der_pol_model(), hand::van_der_pol, [2.0, 0.0], 20.0);
}

//! Lie-group integrators (`LieEuler`, `Rkmk4`, `Cf4`) through the driver: observed
//! orders by least squares against closed forms (the free symmetric top on SO(3)×ℝ³,
//! SE(3) with a time-varying twist in both trivialisations), orthogonality over 10⁶
//! steps against RK45 on the nine entries, constant twists exact, adaptive RKMK4 at a
//! loose and a tight tolerance, events and breakpoints, typed errors.

use nalgebra::{SVector, U12, Vector3, Vector6, vector};
use reckon::lie::{Layout, Se3, So3};
use reckon::methods::{Cf4, LieEuler, Method, Rk45, Rkmk4};
use reckon::vehicles::{body_se3, rigid_body};
use reckon::{Controls, Direction, Error, Event, Options, Problem, Save, StepSize, model};

type X = SVector<f64, 12>;

/// Least-squares slope of `log err` against `log h`.
fn slope(h: &[f64], e: &[f64]) -> f64 {
    let n = h.len() as f64;
    let (x, y): (Vec<f64>, Vec<f64>) = h.iter().zip(e).map(|(h, e)| (h.ln(), e.ln())).unzip();
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&y).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = x.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

fn sci(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:.3e}")).collect::<Vec<_>>().join(", ")
}

fn orth(x: &X) -> f64 {
    let (r, _) = rigid_body::split(x);
    (r.matrix().transpose() * r.matrix() - nalgebra::Matrix3::identity()).amax()
}

// ---------------------------------------------------------------- symmetric top

const I1: f64 = 2.0;
const I3: f64 = 3.0;
const T_TOP: f64 = 4.0;

fn top_start() -> (So3, Vector3<f64>) {
    (So3::exp(&vector![0.3, -0.2, 0.5]), vector![0.6, -0.3, 1.0])
}

/// Max-norm error of `(R, ω)` at `T_TOP` against the closed form.
fn top_error(x: &X) -> f64 {
    let (r0, w0) = top_start();
    let (r_ex, w_ex) = rigid_body::symmetric_top(I1, I3, &r0, &w0, T_TOP);
    let (r, w) = rigid_body::split(x);
    (r.matrix() - r_ex.matrix()).amax().max((w - w_ex).amax())
}

fn top_run<M: Method<U12>>(m: M, opts: &Options) -> reckon::Solution<U12> {
    let (r0, w0) = top_start();
    let f = rigid_body::model([I1, I1, I3]);
    Problem::new(&f, rigid_body::state(&r0, &w0), (0.0, T_TOP))
        .solve(m, opts)
        .unwrap()
}

fn fixed(h: f64) -> Options {
    Options::default().step(StepSize::Fixed(h)).save(Save::End)
}

/// Observed order of `make()` on the top over `steps`, with the errors.
fn top_order<M: Method<U12>>(make: impl Fn() -> M, steps: &[usize]) -> (f64, Vec<f64>) {
    let h: Vec<f64> = steps.iter().map(|&n| T_TOP / n as f64).collect();
    let e: Vec<f64> = h
        .iter()
        .map(|&h| top_error(top_run(make(), &fixed(h)).last().1))
        .collect();
    (slope(&h, &e), e)
}

#[test]
fn symmetric_top_closed_form_matches_an_independent_fine_run() {
    // RK45 on the ambient entries, tight: an independent check of the closed form
    let sol = top_run(Rk45, &Options::default().rtol(1e-13).atol(1e-13).save(Save::End));
    let e = top_error(sol.last().1);
    eprintln!("closed form vs RK45 at 1e-13: {e:.3e}");
    assert!(e < 1e-11, "{e:e}");
    // a wrong precession rate (λ of the other sign) is far off
    let (r0, w0) = top_start();
    let (_, w_bad) = rigid_body::symmetric_top(I3, I1, &r0, &w0, T_TOP);
    assert!((rigid_body::split(sol.last().1).1 - w_bad).amax() > 0.1);
}

#[test]
fn orders_on_the_symmetric_top() {
    let (p, e) = top_order(|| LieEuler::new(rigid_body::layout()), &[200, 400, 800, 1600]);
    eprintln!("top: lie_euler order {p:.4}, errors [{}]", sci(&e));
    assert!((p - 1.0).abs() <= 0.1, "Lie–Euler order {p}");
    let (p, e) = top_order(|| Rkmk4::new(rigid_body::layout()), &[40, 80, 160, 320]);
    eprintln!("top: rkmk4 order {p:.4}, errors [{}]", sci(&e));
    assert!((p - 4.0).abs() <= 0.1, "RKMK4 order {p}");
    let (p, e) = top_order(|| Cf4::new(rigid_body::layout()), &[40, 80, 160, 320]);
    eprintln!("top: cf4 order {p:.4}, errors [{}]", sci(&e));
    assert!((p - 4.0).abs() <= 0.1, "CF4 order {p}");
}

// ---------------------------------------------------------------- SE(3), time-varying twist

const XA: [f64; 6] = [0.4, -0.3, 0.9, 1.0, 0.2, -0.5];
const XB: [f64; 6] = [-0.6, 0.5, 0.2, 0.3, -0.8, 0.4];
const T_SE3: f64 = 2.0;

fn xa() -> Vector6<f64> {
    Vector6::from_column_slice(&XA)
}
fn xb() -> Vector6<f64> {
    Vector6::from_column_slice(&XB)
}
fn g0() -> Se3 {
    Se3::new(So3::exp(&vector![0.2, 0.7, -0.4]), vector![1.0, -2.0, 0.5])
}

/// Right form: `Y(t) = Y₀·Exp(tξ_a)·Exp(tξ_b)` solves `Ẏ = Y·ξ̂(t)` with
/// `ξ(t) = Ad_{Exp(−tξ_b)}·ξ_a + ξ_b`.
fn twist_right(t: f64) -> Vector6<f64> {
    Se3::exp(&(-xb() * t)).adjoint() * xa() + xb()
}
/// Left form: `Y(t) = Exp(tξ_b)·Exp(tξ_a)·Y₀` solves `Ẏ = ξ̂(t)·Y` with
/// `ξ(t) = ξ_b + Ad_{Exp(tξ_b)}·ξ_a`.
fn twist_left(t: f64) -> Vector6<f64> {
    xb() + Se3::exp(&(xb() * t)).adjoint() * xa()
}

fn se3_exact(left: bool, t: f64) -> Se3 {
    let (a, b) = (Se3::exp(&(xa() * t)), Se3::exp(&(xb() * t)));
    if left {
        b.compose(&a).compose(&g0())
    } else {
        g0().compose(&a).compose(&b)
    }
}

fn se3_error(left: bool, x: &X) -> f64 {
    let (g, e) = (body_se3::pose(x), se3_exact(left, T_SE3));
    (g.rotation.matrix() - e.rotation.matrix())
        .amax()
        .max((g.translation - e.translation).amax())
}

fn se3_run<M: Method<U12>>(left: bool, m: M, opts: &Options) -> X {
    let x0 = body_se3::state(&g0());
    let sol = if left {
        // Ṙ = ω̂·R, ṗ = ω × p + v
        let f = model!(|t, x: [S; 12]| {
            let xi = twist_left(t);
            let (w1, w2, w3, v1, v2, v3) = (xi[0], xi[1], xi[2], xi[3], xi[4], xi[5]);
            vector![
                x[2] * w2 - x[1] * w3,
                x[0] * w3 - x[2] * w1,
                x[1] * w1 - x[0] * w2,
                x[5] * w2 - x[4] * w3,
                x[3] * w3 - x[5] * w1,
                x[4] * w1 - x[3] * w2,
                x[8] * w2 - x[7] * w3,
                x[6] * w3 - x[8] * w1,
                x[7] * w1 - x[6] * w2,
                x[11] * w2 - x[10] * w3 + v1,
                x[9] * w3 - x[11] * w1 + v2,
                x[10] * w1 - x[9] * w2 + v3
            ]
        });
        Problem::new(&f, x0, (0.0, T_SE3)).solve(m, opts)
    } else {
        // Ṙ = R·ω̂, ṗ = R·v
        let f = model!(|t, x: [S; 12]| {
            let xi = twist_right(t);
            let (w1, w2, w3, v1, v2, v3) = (xi[0], xi[1], xi[2], xi[3], xi[4], xi[5]);
            vector![
                x[3] * w3 - x[6] * w2,
                x[4] * w3 - x[7] * w2,
                x[5] * w3 - x[8] * w2,
                x[6] * w1 - x[0] * w3,
                x[7] * w1 - x[1] * w3,
                x[8] * w1 - x[2] * w3,
                x[0] * w2 - x[3] * w1,
                x[1] * w2 - x[4] * w1,
                x[2] * w2 - x[5] * w1,
                x[0] * v1 + x[3] * v2 + x[6] * v3,
                x[1] * v1 + x[4] * v2 + x[7] * v3,
                x[2] * v1 + x[5] * v2 + x[8] * v3
            ]
        });
        Problem::new(&f, x0, (0.0, T_SE3)).solve(m, opts)
    };
    *sol.unwrap().last().1
}

fn se3_order<M: Method<U12>>(left: bool, make: impl Fn(Layout) -> M, steps: &[usize]) -> (f64, Vec<f64>) {
    let layout = || {
        if left {
            Layout::left().se3(0)
        } else {
            Layout::right().se3(0)
        }
    };
    let h: Vec<f64> = steps.iter().map(|&n| T_SE3 / n as f64).collect();
    let e: Vec<f64> = h
        .iter()
        .map(|&h| se3_error(left, &se3_run(left, make(layout()), &fixed(h))))
        .collect();
    (slope(&h, &e), e)
}

#[test]
fn orders_on_se3_with_a_time_varying_twist() {
    for left in [false, true] {
        let form = if left { "left" } else { "right" };
        // the closed form against an independent tight RK45 run on the entries
        let e = se3_error(left, &se3_run(left, Rk45, &Options::default().rtol(1e-13).atol(1e-13)));
        eprintln!("se3 {form}: closed form vs RK45 at 1e-13: {e:.3e}");
        assert!(e < 1e-11, "{form}: {e:e}");
        let (p, e) = se3_order(left, LieEuler::new, &[200, 400, 800, 1600]);
        eprintln!("se3 {form}: lie_euler order {p:.4}, errors [{}]", sci(&e));
        assert!((p - 1.0).abs() <= 0.1, "{form}: Lie–Euler order {p}");
        let (p, e) = se3_order(left, Rkmk4::new, &[20, 40, 80, 160]);
        eprintln!("se3 {form}: rkmk4 order {p:.4}, errors [{}]", sci(&e));
        assert!((p - 4.0).abs() <= 0.1, "{form}: RKMK4 order {p}");
        let (p, e) = se3_order(left, Cf4::new, &[20, 40, 80, 160]);
        eprintln!("se3 {form}: cf4 order {p:.4}, errors [{}]", sci(&e));
        assert!((p - 4.0).abs() <= 0.1, "{form}: CF4 order {p}");
    }
}

// ---------------------------------------------------------------- orthogonality

#[test]
fn attitude_stays_orthogonal_over_a_million_steps_where_rk45_drifts() {
    // an asymmetric body (tumbling, ω not constant), h = 1e-3, 10⁶ steps
    let (r0, w0) = (So3::exp(&vector![0.3, -0.2, 0.5]), vector![0.6, -0.3, 1.0]);
    let f = rigid_body::model([1.0, 2.0, 3.0]);
    let x0 = rigid_body::state(&r0, &w0);
    let opts = Options::default()
        .step(StepSize::Fixed(1e-3))
        .save(Save::End)
        .max_steps(2_000_000);
    let p = Problem::new(&f, x0, (0.0, 1000.0));
    let start = std::time::Instant::now();
    let lie = p.solve(Rkmk4::new(rigid_body::layout()), &opts).unwrap();
    let secs = start.elapsed().as_secs_f64();
    let o_lie = orth(lie.last().1);
    eprintln!(
        "rkmk4, 1e6 steps of 1e-3: ‖RᵀR − I‖_max = {o_lie:.3e} ({} steps, {secs:.2} s)",
        lie.stats.accepted
    );
    assert_eq!(lie.stats.accepted, 1_000_000);
    assert!(o_lie <= 1e-13, "{o_lie:e}");
    // RK45 on the nine entries: adaptive at the default tolerances, and at 1e-10
    let rk = p
        .solve(Rk45, &Options::default().save(Save::End).max_steps(2_000_000))
        .unwrap();
    let o_rk = orth(rk.last().1);
    let rk_tight = p
        .solve(
            Rk45,
            &Options::default()
                .rtol(1e-10)
                .atol(1e-10)
                .save(Save::End)
                .max_steps(2_000_000),
        )
        .unwrap();
    let o_tight = orth(rk_tight.last().1);
    eprintln!(
        "rk45 over t = 1000: ‖RᵀR − I‖_max = {o_rk:.3e} at rtol 1e-6 ({} steps), {o_tight:.3e} at 1e-10 ({} steps)",
        rk.stats.accepted, rk_tight.stats.accepted
    );
    // measured 2.2e-4 and 1.1e-7: RK45 leaves the group by its tolerance, RKMK4 does not
    assert!(o_rk > 1e-5, "{o_rk:e}");
    assert!(o_tight > 1e-8, "{o_tight:e}");
}

// ---------------------------------------------------------------- constant twist

#[test]
fn a_constant_twist_is_integrated_exactly() {
    let twist = vector![0.3, -0.2, 0.5, 1.0, 0.2, -0.1];
    let g = Se3::new(So3::exp(&vector![0.4, 0.1, -0.3]), vector![0.5, 1.0, -1.0]);
    let c = Controls::new(vec![0.0, 3.0], vec![twist.as_slice().to_vec(), vec![0.0; 6]]).unwrap();
    let exact = body_se3::flow(&g, &twist, 3.0);
    let f = body_se3::model();
    let p = Problem::new(&f, body_se3::state(&g), (0.0, 3.0)).controls(c);
    let miss = |x: &X| {
        let e = body_se3::pose(x);
        (e.rotation.matrix() - exact.rotation.matrix())
            .amax()
            .max((e.translation - exact.translation).amax())
    };
    for h in [3.0, 0.3] {
        let e = [
            miss(p.solve(LieEuler::new(body_se3::layout()), &fixed(h)).unwrap().last().1),
            miss(p.solve(Rkmk4::new(body_se3::layout()), &fixed(h)).unwrap().last().1),
            miss(p.solve(Cf4::new(body_se3::layout()), &fixed(h)).unwrap().last().1),
        ];
        eprintln!("constant twist, h = {h}: lie_euler, rkmk4, cf4 miss [{}]", sci(&e));
        assert!(e.iter().all(|&e| e < 1e-14), "h = {h}: [{}]", sci(&e));
    }
    // adaptive RKMK4: a zero estimate, so one step
    let sol = p.solve(Rkmk4::new(body_se3::layout()), &Options::default()).unwrap();
    assert!(miss(sol.last().1) < 1e-14);
    assert!(sol.stats.accepted <= 6, "{} steps", sol.stats.accepted);
}

// ---------------------------------------------------------------- adaptive

#[test]
fn adaptive_rkmk4_meets_a_loose_and_a_tight_tolerance() {
    let mut last = (f64::INFINITY, 0);
    for tol in [1e-4, 1e-7, 1e-10] {
        let sol = top_run(
            Rkmk4::new(rigid_body::layout()),
            &Options::default().rtol(tol).atol(tol).save(Save::End),
        );
        let e = top_error(sol.last().1);
        let s = sol.stats;
        eprintln!(
            "adaptive rkmk4 at tol {tol:e}: error {e:.3e}, {} steps ({} rejected), {} f calls",
            s.accepted, s.rejected, s.rhs_evals
        );
        // state entries are O(1): within 10× the tolerance, and well resolved
        assert!(e <= 10.0 * tol, "tol {tol:e}: error {e:e}");
        assert!(e < last.0 && s.accepted > last.1);
        // 4 f calls per step (FSAL), plus the first and the initial step's probe
        let steps = s.accepted + s.rejected;
        assert!(
            s.rhs_evals >= 4 * steps && s.rhs_evals <= 4 * steps + 3,
            "{} f calls",
            s.rhs_evals
        );
        last = (e, s.accepted);
    }
    // CF4 has no estimate: adaptive is refused with a typed error
    let f = rigid_body::model([I1, I1, I3]);
    let (r0, w0) = top_start();
    let err = Problem::new(&f, rigid_body::state(&r0, &w0), (0.0, 1.0))
        .solve(Cf4::new(rigid_body::layout()), &Options::default())
        .unwrap_err();
    assert!(matches!(err, Error::InvalidInput { what: "step", .. }), "{err:?}");
}

// ---------------------------------------------------------------- events, breakpoints

#[test]
fn events_and_breakpoints_with_rkmk4() {
    // forward at 1 m/s turning at 0.5 rad/s about z for t < 2, then straight on at 2 m/s
    let (a, b) = (
        vector![0.0, 0.0, 0.5, 1.0, 0.0, 0.0],
        vector![0.0, 0.0, 0.0, 2.0, 0.0, 0.0],
    );
    let c = Controls::new(
        vec![0.0, 2.0, 6.0],
        vec![a.as_slice().to_vec(), b.as_slice().to_vec(), vec![0.0; 6]],
    )
    .unwrap();
    let g0 = Se3::identity();
    let exact = |t: f64| {
        if t <= 2.0 {
            body_se3::flow(&g0, &a, t)
        } else {
            body_se3::flow(&body_se3::flow(&g0, &a, 2.0), &b, t - 2.0)
        }
    };
    // world y crosses 2.5, in the straight part: t* solves y(2) + 2 sin(1)(t − 2) = 2.5
    let y2 = exact(2.0).translation[1];
    let t_star = 2.0 + (2.5 - y2) / (2.0 * 1.0f64.sin());
    let f = body_se3::model();
    let cross = Event::new(|_t, x: &X| x[10] - 2.5).direction(Direction::Rising);
    let sol = Problem::new(&f, body_se3::state(&g0), (0.0, 6.0))
        .controls(c)
        .event(cross)
        .solve(
            Rkmk4::new(body_se3::layout()),
            &Options::default().rtol(1e-10).atol(1e-10).dense(true),
        )
        .unwrap();
    assert!(sol.t.contains(&2.0), "the breakpoint is a step end");
    assert_eq!(sol.events.len(), 1);
    let hit = &sol.events[0];
    let end = body_se3::pose(sol.last().1);
    let e_end = (end.translation - exact(6.0).translation).amax();
    eprintln!(
        "event at {:.15} (exact {t_star:.15}, miss {:.2e}); end miss {e_end:.2e}; {} steps",
        hit.t,
        (hit.t - t_star).abs(),
        sol.stats.accepted
    );
    assert!((hit.t - t_star).abs() < 1e-9, "{} vs {t_star}", hit.t);
    assert!((hit.x[10] - 2.5).abs() < 1e-9);
    assert!(e_end < 1e-9, "{e_end:e}");
    // dense output between steps, in the turning part: the quartic through the midpoint
    let mid = sol.at(1.3).unwrap();
    let e_mid = (body_se3::pose(&mid).translation - exact(1.3).translation).amax();
    eprintln!("dense output at t = 1.3: miss {e_mid:.2e}");
    assert!(e_mid < 1e-8, "{e_mid:e}");
}

// ---------------------------------------------------------------- errors

#[test]
fn bad_layouts_and_states_off_the_group_are_typed_errors() {
    let f = rigid_body::model([1.0, 2.0, 3.0]);
    let mut x0 = rigid_body::state(&So3::identity(), &vector![1.0, 0.0, 0.0]);
    let p = Problem::new(&f, x0, (0.0, 1.0));
    let o = fixed(0.1);
    // a block past the end of the state
    let e = p.solve(LieEuler::new(Layout::right().so3(4)), &o).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "layout", .. }), "{e:?}");
    let e = p.solve(Rkmk4::new(Layout::right().se3(1)), &o).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "layout", .. }), "{e:?}");
    // two overlapping blocks
    let e = p.solve(Cf4::new(Layout::right().so3(0).so3(2)), &o).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "layout", .. }), "{e:?}");
    // not a rotation: scaled, and a reflection
    x0[0] = 1.0 + 1e-6;
    let e = Problem::new(&f, x0, (0.0, 1.0))
        .solve(Rkmk4::new(rigid_body::layout()), &o)
        .unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "x0", .. }), "{e:?}");
    x0[0] = -1.0;
    let e = Problem::new(&f, x0, (0.0, 1.0))
        .solve(Cf4::new(rigid_body::layout()), &o)
        .unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "x0", .. }), "{e:?}");
}

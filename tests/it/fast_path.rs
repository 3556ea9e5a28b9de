//! The fixed-step fast path of `solve` (exact flows and explicit Euler with nothing to
//! stop for but breakpoints) against the general path (the same run with an event that
//! never fires, and the step-by-step integrator) and a bare loop, on a 10⁴-interval log:
//! every stored step bit for bit, breakpoints landed exactly, inputs switched on time.

use nalgebra::{Vector3, vector};
use reckon::error::Quantity;
use reckon::methods::{Euler, Exact, Method};
use reckon::vehicles::unicycle;
use reckon::{Controls, Error, Event, Options, Problem, Save, Solution, model};

const N: usize = 10_000;

/// Irregular control times (no step divides them) and inputs that change every interval.
fn log(t0: f64) -> Controls {
    let times: Vec<f64> = (0..N)
        .map(|k| t0 + k as f64 * 0.01 + 0.003 * ((k * 7919) % 13) as f64 / 13.0)
        .collect();
    let values = (0..N)
        .map(|k| vec![1.0 + 0.5 * (k as f64 * 1e-2).sin(), 0.8 * (k as f64 * 7e-3).cos()])
        .collect();
    Controls::new(times, values).unwrap()
}

type Sys = reckon::nalgebra::Const<3>;
type Run = (Solution<Sys>, Solution<Sys>, Vec<(f64, Vector3<f64>)>);

/// `p` with an event that never fires: the same run through the general path.
fn with_idle_event<'a, S: reckon::System<Sys> + Copy>(p: &Problem<'a, Sys, S>) -> Problem<'a, Sys, S> {
    Problem::new(p.system, p.x0, (p.t0, p.t_end))
        .controls(p.controls.clone().unwrap())
        .event(Event::new(|_t, x: &Vector3<f64>| x[0] + 1e9))
}

/// The fast path, the general path (an event that never fires) and `step()` one by one.
fn both<S: reckon::System<Sys> + Copy, M: Method<Sys> + Clone>(
    p: &Problem<'_, Sys, S>,
    method: M,
    opts: &Options,
) -> Run {
    let fast = p.solve(method.clone(), opts).unwrap();
    let general = with_idle_event(p).solve(method.clone(), opts).unwrap();
    let stepped: Vec<(f64, Vector3<f64>)> = {
        let mut it = p.integrator(method, opts).unwrap();
        let mut v = vec![(it.t(), *it.x())];
        while let Some(t) = it.step().unwrap() {
            v.push((t, *it.x()));
        }
        v
    };
    (fast, general, stepped)
}

/// An exact flow's fast path against the general path one step at a time (bit for bit,
/// every kept state), and against the run with an idle event: an event makes the
/// exact flow's dense output matter, so that run shortens its steps until the
/// interpolant meets the tolerance (other steps, the same answer at the end).
fn same_exact(f: &Solution<Sys>, g: &Solution<Sys>, stepped: &[(f64, Vector3<f64>)]) {
    same_as_stepped(f, stepped);
    assert_eq!(f.last().0, g.last().0);
    let e = (f.last().1 - g.last().1).amax();
    assert!(e < 1e-9 * f.last().1.amax().max(1.0), "{e:e}");
    assert!(g.stats.accepted >= f.stats.accepted);
}

/// The fast path against the general path one step at a time, bit for bit.
fn same_as_stepped(f: &Solution<Sys>, stepped: &[(f64, Vector3<f64>)]) {
    if f.t.len() == stepped.len() {
        for (k, (t, x)) in stepped.iter().enumerate() {
            assert!(f.t[k] == *t && f.x[k] == *x, "step {k}");
        }
    }
    assert_eq!(*f.last().1, stepped[stepped.len() - 1].1);
}

fn same(a: &Solution<nalgebra::Const<3>>, b: &Solution<nalgebra::Const<3>>) {
    assert_eq!(a.t.len(), b.t.len());
    for k in 0..a.t.len() {
        assert!(a.t[k].to_bits() == b.t[k].to_bits(), "t[{k}]: {} vs {}", a.t[k], b.t[k]);
        for i in 0..3 {
            assert!(a.x[k][i].to_bits() == b.x[k][i].to_bits(), "x[{k}][{i}]");
        }
    }
    assert_eq!(a.stats.accepted, b.stats.accepted);
}

#[test]
fn exact_flow_fast_path_equals_the_general_path_and_a_bare_loop() {
    let c = log(0.0);
    let t_end = c.times()[N - 1] + 0.01;
    let sys = unicycle::model();
    let p = Problem::new(&sys, vector![0.0, 0.0, 0.0], (0.0, t_end)).controls(c.clone());
    let (fast, general, stepped) = both(&p, Exact::new(unicycle::flow), &Options::default());
    same_exact(&fast, &general, &stepped);
    assert_eq!(fast.t.len(), N + 1);
    for (k, (t, x)) in stepped.iter().enumerate() {
        assert!(fast.t[k] == *t && fast.x[k] == *x, "step {k}");
    }
    // every control time is a stored time, exactly, and the inputs switched there: the
    // bare loop x ← φ(x, u_k, t_{k+1} − t_k) gives the same bits
    let mut x = vector![0.0, 0.0, 0.0];
    for k in 0..N {
        assert_eq!(fast.t[k], c.times()[k]);
        let next = if k + 1 < N { c.times()[k + 1] } else { t_end };
        x = unicycle::flow(0.0, &x, c.values(k).unwrap(), next - c.times()[k]);
        assert!(fast.x[k + 1] == x, "interval {k}");
    }
    // the other save modes keep the same states
    for save in [Save::Every(7), Save::End] {
        let o = Options::default().save(save.clone());
        let (f, g, s) = both(&p, Exact::new(unicycle::flow), &o);
        same_exact(&f, &g, &s);
        assert_eq!(*f.last().1, *fast.last().1);
    }
    // an exact flow on a finer grid (0.004: grid points between the control times)
    let o = Options::default().fixed(0.004).breakpoints([0.5, 12.345]);
    let (f, g, s) = both(&p, Exact::new(unicycle::flow), &o);
    same(&f, &g); // fixed steps: the event changes none
    assert!(f.t.len() > 2 * N && f.t.contains(&12.345) && f.t.contains(&c.times()[5000]));
    assert_eq!(s.len(), f.t.len());
}

#[test]
fn fixed_step_euler_fast_path_equals_the_general_path() {
    let c = log(0.0);
    let t_end = c.times()[N - 1] + 0.01;
    let sys = unicycle::model();
    let p = Problem::new(&sys, vector![0.1, -0.2, 0.3], (0.0, t_end)).controls(c);
    for h in [0.01, 0.0037, 1.0] {
        let (f, g, s) = both(&p, Euler, &Options::default().fixed(h));
        same(&f, &g);
        assert_eq!(s.len(), f.t.len());
        assert!(s.iter().zip(&f.x).all(|(a, b)| a.1 == *b));
    }
}

/// Regular logs: at the step's own rate (every grid point is a control time, the fast
/// path's first test), at three times it (two grid steps inside each interval), at half
/// of it (a stop between grid points), and at 0.1 with a step of 0.1/3 (grid points within
/// rounding of the control times, not equal to them): bit for bit the general path's.
#[test]
fn regular_logs_on_and_off_the_step_grid_agree_with_the_general_path() {
    let sys = unicycle::model();
    for (dt, h, n) in [
        (0.01, 0.01, 4000),
        (0.03, 0.01, 2000),
        (0.005, 0.01, 4000),
        (0.1, 0.1 / 3.0, 1000),
    ] {
        let times: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let values = (0..n)
            .map(|k| vec![1.0 + 0.5 * (k as f64 * 1e-2).sin(), 0.8 * (k as f64 * 7e-3).cos()])
            .collect();
        let c = Controls::new(times, values).unwrap();
        let t_end = n as f64 * dt;
        let p = Problem::new(&sys, vector![0.1, -0.2, 0.3], (0.0, t_end)).controls(c);
        let (f, g, s) = both(&p, Euler, &Options::default().fixed(h));
        same(&f, &g);
        assert_eq!(s.len(), f.t.len());
        assert!(s.iter().zip(&f.x).all(|(a, b)| a.1 == *b));
        // steps: one per grid interval, plus one per control time strictly between grid
        // points (the log at half the step puts every other one there)
        let expected = match (dt, h) {
            (0.005, _) => n,
            (0.1, _) => 3 * n,
            _ => (t_end / h).round() as usize,
        };
        assert_eq!(f.stats.accepted as usize, expected, "log every {dt}, step {h}");
    }
}

/// A log at the step's rate is checked a run of stops at a time (each stop the next grid
/// point, none the last): runs broken by a stop off the grid (a grid step before it), a
/// stop within rounding of its grid point (on the grid by tolerance, not by the first
/// test), a missing row (a grid step with no stop), a start inside an interval and a run
/// ending at the log's last stop: bit for bit the general path's, with the steps counted.
#[test]
fn checked_runs_of_a_log_at_the_step_rate_are_the_general_paths() {
    let sys = unicycle::model();
    let h = 0.01;
    let mut times: Vec<f64> = (0..N).map(|k| k as f64 * h).collect();
    times[300] += 0.003;
    times[1000] += 1e-14;
    times[1001] += 0.004;
    times.remove(5000);
    let n = times.len();
    let values = (0..n)
        .map(|k| vec![1.0 + 0.5 * (k as f64 * 1e-2).sin(), 0.8 * (k as f64 * 7e-3).cos()])
        .collect();
    let c = Controls::new(times.clone(), values).unwrap();
    for (t0, t_end) in [(0.0, N as f64 * h), (0.0, 77.77), (12.345, 99.995), (0.0, times[n - 1])] {
        let p = Problem::new(&sys, vector![0.1, -0.2, 0.3], (t0, t_end)).controls(c.clone());
        let (f, g, s) = both(&p, Euler, &Options::default().fixed(h));
        same(&f, &g);
        assert_eq!(s.len(), f.t.len());
        assert!(
            s.iter()
                .zip(f.t.iter().zip(&f.x))
                .all(|(a, (t, x))| a.0 == *t && a.1 == *x)
        );
        // every control time inside the span is a stored time
        assert!(times.iter().filter(|&&t| t > t0 && t < t_end).all(|t| f.t.contains(t)));
        if t0 == 0.0 && t_end == N as f64 * h {
            // one step per grid interval, plus one for each of the two stops off the grid
            // (the third is within rounding: its grid point)
            assert_eq!(f.stats.accepted as usize, N + 2, "{t0} {t_end}");
        }
    }
}

#[test]
fn backwards_and_from_a_late_start_the_paths_agree() {
    let c = log(100.0);
    let sys = unicycle::model();
    let (a, b) = (c.times()[0], c.times()[N - 1] + 0.01);
    // backwards from the end of the log to its start
    let p = Problem::new(&sys, vector![1.0, 2.0, 0.5], (b, a)).controls(c.clone());
    let (f, g, s) = both(&p, Exact::new(unicycle::flow), &Options::default());
    same_exact(&f, &g, &s);
    assert_eq!(f.last().0, a);
    // a span that starts inside an interval
    let p = Problem::new(&sys, vector![0.0, 0.0, 0.0], (a + 12.3456, b)).controls(c);
    let (f, g, _) = both(&p, Euler, &Options::default().fixed(0.02));
    same(&f, &g);
}

#[test]
fn errors_on_the_fast_path_are_the_general_paths() {
    let c = log(0.0);
    let t_end = c.times()[N - 1] + 0.01;
    let sys = unicycle::model();
    // a flow that blows up in interval 5000
    let bad_at = c.times()[5000];
    let flow = move |t: f64, x: &Vector3<f64>, u: &[f64], h: f64| {
        let y = unicycle::flow(t, x, u, h);
        if t == bad_at { vector![f64::NAN, y[1], y[2]] } else { y }
    };
    let q = Problem::new(&sys, vector![0.0, 0.0, 0.0], (0.0, t_end)).controls(c.clone());
    let fast = q.solve(Exact::new(flow), &Options::default()).unwrap_err();
    let mut it = q.integrator(Exact::new(flow), &Options::default()).unwrap();
    let general = loop {
        match it.step() {
            Ok(Some(_)) => {}
            Ok(None) => panic!("no error"),
            Err(e) => break e,
        }
    };
    assert_eq!(fast, general);
    assert!(
        matches!(fast, Error::NonFinite { t, .. } if t == c.times()[5001]),
        "{fast}"
    );
    // the step limit per interval
    let o = Options::default().fixed(1e-4).max_steps(50);
    let fast = q.solve(Euler, &o).unwrap_err();
    let mut it = q.integrator(Euler, &o).unwrap();
    let general = loop {
        match it.step() {
            Ok(Some(_)) => {}
            Ok(None) => panic!("no error"),
            Err(e) => break e,
        }
    };
    assert_eq!(fast, general);
    assert!(matches!(fast, Error::MaxSteps { steps: 50, .. }), "{fast}");
}

#[test]
fn a_span_inside_the_log_switches_inputs_at_the_right_interval() {
    // the stops are the control times inside the span, borrowed from the log, and stop i
    // opens interval lo + i: a span starting exactly on a control time, or inside an
    // interval, and ending before the log does, against a bare loop over the same times
    let c = log(3.0);
    let sys = unicycle::model();
    let times = c.times();
    for (a, b) in [(times[17], times[N - 40] - 0.0021), (times[17] + 0.0042, times[9000])] {
        let p = Problem::new(&sys, vector![0.3, -0.1, 0.2], (a, b)).controls(c.clone());
        let (f, g, s) = both(&p, Exact::new(unicycle::flow), &Options::default());
        same_exact(&f, &g, &s);
        assert_eq!(s.len(), f.t.len());
        let first = times.partition_point(|&t| t <= a);
        let mut x = vector![0.3, -0.1, 0.2];
        let (mut t, mut k, mut i) = (a, first - 1, 0);
        while t < b {
            let next = times.get(k + 1).copied().filter(|&n| n < b).unwrap_or(b);
            // the driver's step is measured from t0: (next − t0) − (t − t0)
            x = unicycle::flow(t, &x, c.values(k).unwrap(), (next - a) - (t - a));
            i += 1;
            assert!(f.t[i] == next && f.x[i] == x, "stored step {i} at t = {next}");
            (t, k) = (next, k + 1);
        }
        assert_eq!(i + 1, f.t.len());
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(96))]
    /// Random logs and spans: the borrowed stops with stop i opening interval lo + i give
    /// what the merged, searched stops give (a breakpoint on one of the control times
    /// inside the span forces that path and changes no stop), for `Exact` and for
    /// explicit Euler, and what a bare loop gives for `Exact`.
    #[test]
    fn borrowed_stops_equal_merged_stops(
        gaps in proptest::collection::vec(0.001f64..0.5, 1..40),
        start in 0.0f64..1.0,
        len in 0.0f64..1.2,
        h in 0.003f64..0.4,
    ) {
        let mut times = vec![2.0];
        for g in &gaps {
            let last = *times.last().unwrap();
            times.push(last + g);
        }
        let values: Vec<Vec<f64>> = (0..times.len())
            .map(|k| vec![1.0 + 0.1 * k as f64, 0.7 - 0.05 * k as f64])
            .collect();
        let c = Controls::new(times.clone(), values).unwrap();
        let span_all = times[times.len() - 1] + 0.3 - times[0];
        let a = times[0] + start * span_all;
        let b = a + len.max(1e-3) * span_all;
        let sys = unicycle::model();
        let p = Problem::new(&sys, vector![0.1, 0.2, 0.3], (a, b)).controls(c.clone());
        let inside: Vec<f64> = times.iter().copied().filter(|&t| t > a && t < b).collect();
        for (method_is_exact, opts) in [(true, Options::default()), (false, Options::default().fixed(h))] {
            let merged_opts = match inside.first() {
                Some(&t) => opts.clone().breakpoints([t]),
                None => opts.clone(),
            };
            let (fast, merged) = if method_is_exact {
                (
                    p.solve(Exact::new(unicycle::flow), &opts).unwrap(),
                    p.solve(Exact::new(unicycle::flow), &merged_opts).unwrap(),
                )
            } else {
                (p.solve(Euler, &opts).unwrap(), p.solve(Euler, &merged_opts).unwrap())
            };
            same(&fast, &merged);
            if method_is_exact {
                // one step per interval: x ← φ(x, u_k, (next − a) − (t − a))
                let mut x = vector![0.1, 0.2, 0.3];
                let (mut t, mut i) = (a, 0);
                let mut k = times.partition_point(|&s| s <= a) - 1;
                while t < b {
                    let next = times.get(k + 1).copied().filter(|&s| s < b).unwrap_or(b);
                    x = unicycle::flow(t, &x, c.values(k).unwrap(), (next - a) - (t - a));
                    i += 1;
                    proptest::prop_assert!(fast.t[i] == next && fast.x[i] == x, "step {} at {}", i, next);
                    (t, k) = (next, k + 1);
                }
                proptest::prop_assert_eq!(i + 1, fast.t.len());
            }
        }
    }
}

/// The fast path keeps the state alternately in two buffers: every way out of it (the
/// end of the span, a landing without a step, a non-finite step, the step limit) after
/// an even and after an odd number of steps, on a log (stops = the log's times) and with
/// a breakpoint (stops merged): bit for bit the general path's states and errors.
#[test]
fn every_exit_after_an_odd_and_an_even_number_of_steps_is_the_general_paths() {
    let sys = unicycle::model();
    // from t0 = −50, the times 0, 1e−16 and 2e−16 are one t − t0 (50): the last two
    // are landed on without a step
    for skip in [0, 1] {
        let mut times: Vec<f64> = (0..50).filter(|&k| k != 1 + skip).map(|k| k as f64 - 50.0).collect();
        times.extend([0.0, 1e-16, 2e-16]);
        times.extend((1..=7).map(|k| k as f64));
        let n = times.len();
        let values: Vec<Vec<f64>> = (0..n)
            .map(|k| vec![1.0 + 0.1 * k as f64, 0.3 - 0.01 * k as f64])
            .collect();
        let c = Controls::new(times.clone(), values).unwrap();
        for t_end in [7.5, 8.0] {
            let p = Problem::new(&sys, vector![0.1, -0.2, 0.3], (-50.0, t_end)).controls(c.clone());
            for opts in [Options::default(), Options::default().breakpoints([-20.5])] {
                let (f, g, s) = both(&p, Exact::new(unicycle::flow), &opts);
                same_exact(&f, &g, &s);
                assert_eq!(s.len(), f.t.len());
                // one step per interval, none for the two landings
                let stops = n - 1 + opts.breakpoints.len();
                assert_eq!(f.stats.accepted as usize, stops + 1 - 2, "skip {skip}, t_end {t_end}");
                for h in [0.5, 1.0] {
                    let o = opts.clone().fixed(h);
                    let (f, g, s) = both(&p, Euler, &o);
                    same(&f, &g);
                    assert!(s.iter().zip(&f.x).all(|(a, b)| a.1 == *b));
                }
            }
            // a flow that fails in interval `bad` (odd and even step counts before it)
            for bad in [10, 11, 52, 53] {
                let at = times[bad];
                let flow = move |t: f64, x: &Vector3<f64>, u: &[f64], h: f64| {
                    let y = unicycle::flow(t, x, u, h);
                    if t == at { vector![y[0], f64::INFINITY, y[2]] } else { y }
                };
                let fast = p.solve(Exact::new(flow), &Options::default()).unwrap_err();
                let mut it = p.integrator(Exact::new(flow), &Options::default()).unwrap();
                let general = loop {
                    match it.step() {
                        Ok(Some(_)) => {}
                        Ok(None) => panic!("no error"),
                        Err(e) => break e,
                    }
                };
                assert_eq!(fast, general);
                // (the diagnosis reads the failed step's result: component 1)
                assert!(
                    matches!(fast, Error::NonFinite { t, quantity: Quantity::State, component: 1 } if t == times[bad + 1]),
                    "{fast}"
                );
                // explicit Euler on a model whose derivative overflows with that row's input
                let v_bad = 1.0 + 0.1 * bad as f64;
                let g = model!(|_t, x: [S; 3], u: [2]| vector![
                    x[2].cos() * u[0] * if u[0] == v_bad { 1e308 } else { 1.0 } * 1e10,
                    x[2].sin() * u[0],
                    x[0] * 0.0 + u[1]
                ]);
                let q = Problem::new(&g, vector![0.1, -0.2, 0.3], (-50.0, t_end)).controls(c.clone());
                let o = Options::default().fixed(0.5);
                let fast = q.solve(Euler, &o).unwrap_err();
                let general = with_idle_event(&q).solve(Euler, &o).unwrap_err();
                assert_eq!(fast, general);
                assert!(matches!(fast, Error::NonFinite { component: 0, .. }), "{fast}");
            }
            // the step limit, reached in an odd and in an even step of one interval
            for limit in [3, 4] {
                let o = Options::default().fixed(1e-3).max_steps(limit);
                let fast = p.solve(Euler, &o).unwrap_err();
                let mut it = p.integrator(Euler, &o).unwrap();
                let general = loop {
                    match it.step() {
                        Ok(Some(_)) => {}
                        Ok(None) => panic!("no error"),
                        Err(e) => break e,
                    }
                };
                assert_eq!(fast, general);
                assert!(
                    matches!(fast, Error::MaxSteps { steps, .. } if steps == limit),
                    "{fast}"
                );
            }
        }
    }
}

/// `solve` on an integrator already stepped by hand (the fast path then starts inside an
/// interval, with steps counted against the limit) against the same with an event that
/// never fires: the same steps after, or the same `MaxSteps` error, at entry and after.
#[test]
fn solve_after_steps_by_hand_is_the_general_paths() {
    let c = log(0.0);
    // 100 intervals of 0.010–0.013, 100–130 steps of 1e-4 each
    let t_end = c.times()[99] + 0.01;
    let sys = unicycle::model();
    let x0 = vector![0.0, 0.0, 0.0];
    let fast_p = Problem::new(&sys, x0, (0.0, t_end)).controls(c.clone());
    let general_p = with_idle_event(&fast_p);
    // every time, stepped by hand
    let all: Vec<f64> = {
        let mut it = fast_p.integrator(Euler, &Options::default().fixed(1e-4)).unwrap();
        std::iter::once(0.0)
            .chain(std::iter::from_fn(|| it.step().unwrap()))
            .collect()
    };
    for (taken, limit) in [(0, 100_000), (7, 100_000), (250, 100_000), (29, 30), (30, 30), (3, 30)] {
        let o = Options::default().fixed(1e-4).max_steps(limit);
        let run = |p: &Problem<'_, Sys, _>| {
            let mut it = p.integrator(Euler, &o).unwrap();
            for _ in 0..taken {
                it.step().unwrap().unwrap();
            }
            it.solve()
        };
        match (run(&fast_p), run(&general_p)) {
            (Ok(f), Ok(g)) => {
                assert!(limit > 130, "{taken} by hand, limit {limit}: no error");
                same(&f, &g);
                assert_eq!(f.t, all[taken..], "{taken} by hand");
                assert_eq!(*f.t.last().unwrap(), t_end);
            }
            (Err(f), Err(g)) => {
                assert_eq!(f, g, "{taken} by hand, limit {limit}");
                assert!(
                    matches!(f, Error::MaxSteps { steps: 30, t } if t > 0.0029 && t < 0.00301),
                    "{f}"
                );
            }
            (f, g) => panic!("{taken} by hand, limit {limit}: {f:?} vs {g:?}"),
        }
    }
}

/// Inputs set by hand (`set_inputs`, owned values, not a row of the log) before `solve`:
/// the fast path takes the general step until the next stop holds a row, then its own
/// loop; every step the general path's, bit for bit, and the inputs set are used.
#[test]
fn inputs_set_by_hand_then_solve_is_the_general_paths() {
    let c = log(0.0);
    let t_end = c.times()[199] + 0.01;
    let sys = unicycle::model();
    let x0 = vector![0.0, 0.0, 0.0];
    let fast_p = Problem::new(&sys, x0, (0.0, t_end)).controls(c.clone());
    let general_p = with_idle_event(&fast_p);
    fn run<M: Method<Sys> + Clone, S: reckon::System<Sys>>(
        p: &Problem<'_, Sys, S>,
        m: M,
        o: &Options,
        set: bool,
    ) -> Solution<Sys> {
        let mut it = p.integrator(m, o).unwrap();
        for _ in 0..3 {
            it.step().unwrap().unwrap();
        }
        if set {
            it.set_inputs(&[0.7, -2.0]).unwrap();
        }
        it.solve().unwrap()
    }
    let euler = Options::default().fixed(0.004);
    let exact = Options::default();
    let flow = || Exact::new(unicycle::flow);
    for set in [true, false] {
        // (with an event the exact flow's steps differ, so its three steps end elsewhere:
        // the general path is the one stepped by hand)
        let f = run(&fast_p, flow(), &exact, set);
        // the general path one step at a time, after the same three steps and inputs
        let mut it = fast_p.integrator(flow(), &exact).unwrap();
        let mut stepped = vec![(it.t(), *it.x())];
        for k in 0.. {
            if k == 3 && set {
                it.set_inputs(&[0.7, -2.0]).unwrap();
            }
            match it.step().unwrap() {
                Some(t) => stepped.push((t, *it.x())),
                None => break,
            }
        }
        same_as_stepped(&f, &stepped);
        let (f, g) = (run(&fast_p, Euler, &euler, set), run(&general_p, Euler, &euler, set));
        same(&f, &g);
    }
    // the inputs set are the ones used: after three steps (three intervals of the log)
    // the exact flow turns at −2 rad/s until the fourth control time
    let f = run(&fast_p, flow(), &exact, true);
    assert_eq!(f.t[1], c.times()[4]);
    let heading = |s: &Solution<Sys>, k: usize| s.x[k][2];
    let h = c.times()[4] - c.times()[3];
    assert_eq!(heading(&f, 1), heading(&f, 0) - 2.0 * h);
    let unset = run(&fast_p, flow(), &exact, false);
    assert_eq!(heading(&unset, 1), heading(&unset, 0) + c.values(3).unwrap()[1] * h);
}

/// A log at the step's rate is told apart a block of stops at a time, out of the loop:
/// runs on the grid of every length around the block sizes (shorter than the shortest
/// run the one-step-per-stop loop takes, as long, longer; around the longest stretch
/// looked at once), each broken by a stop off the grid, one just inside and one just
/// outside the grid test's tolerance, one within rounding, a missing row and an extra
/// stop between grid points; forwards and backwards, with breakpoints, with every save
/// mode, and failing inside a run and at its edges: bit for bit the general path's, with
/// the steps counted (a stop outside the tolerance taken as on the grid saves a step).
#[test]
fn runs_on_the_grid_of_every_length_broken_every_way_are_the_general_paths() {
    let sys = unicycle::model();
    let h = 0.01;
    let runs = [15, 16, 17, 1, 7, 8, 9, 2047, 2048, 2049, 3, 4100, 31, 33, 2, 0, 0, 40];
    let (mut times, mut k, mut extra_steps) = (vec![], 0usize, 0);
    for (r, &len) in runs.iter().enumerate() {
        times.extend((k..k + len).map(|j| j as f64 * h));
        k += len;
        let g = k as f64 * h;
        match r % 6 {
            0 => times.push(g + 0.3 * h),
            1 => times.push(g + 0.9e-10 * h),
            2 => times.push(g + 1.1e-10 * h),
            3 => times.push(g + 1e-15),
            4 => {} // a missing row
            _ => times.extend([g, g + 0.5 * h]),
        }
        extra_steps += usize::from(matches!(r % 6, 0 | 2 | 5));
        k += 1;
    }
    times.extend((k..k + 20).map(|j| j as f64 * h));
    let m = k + 20;
    let n = times.len();
    let values: Vec<Vec<f64>> = (0..n)
        .map(|k| vec![1.0 + 0.5 * (k as f64 * 1e-2).sin(), 0.8 * (k as f64 * 7e-3).cos()])
        .collect();
    let c = Controls::new(times.clone(), values).unwrap();
    let t_end = m as f64 * h;
    let x0 = vector![0.1, -0.2, 0.3];
    let fwd = Problem::new(&sys, x0, (0.0, t_end)).controls(c.clone());
    let bwd = Problem::new(&sys, x0, (t_end, 0.0)).controls(c.clone());
    // (from inside a run, on the grid of the log and off it)
    let late = Problem::new(&sys, x0, (20.0, 61.0)).controls(c.clone());
    let off = Problem::new(&sys, x0, (20.004, 61.0)).controls(c.clone());
    let opts = Options::default().fixed(h);
    for (p, o) in [
        (&fwd, opts.clone()),
        (&fwd, opts.clone().save(Save::Every(7))),
        (&fwd, opts.clone().save(Save::End)),
        (
            &fwd,
            opts.clone().breakpoints([times[30], 21.0 + 0.25 * h, times[2100]]),
        ),
        (&bwd, opts.clone()),
        (&bwd, opts.clone().breakpoints([times[5000]])),
        (&late, opts.clone()),
        (&off, opts.clone()),
    ] {
        let (f, g, s) = both(p, Euler, &o);
        same(&f, &g);
        if o.save == Save::default() {
            assert_eq!(s.len(), f.t.len());
            assert!(
                s.iter()
                    .zip(f.t.iter().zip(&f.x))
                    .all(|(a, (t, x))| a.0 == *t && a.1 == *x)
            );
        } else {
            assert_eq!(*f.last().1, s.last().unwrap().1);
        }
        let (f, g, _) = both(p, Exact::new(unicycle::flow), &o);
        same(&f, &g);
    }
    // one step per grid interval, one more for each stop the grid test puts off the grid
    let f = fwd.solve(Euler, &opts).unwrap();
    assert_eq!(f.stats.accepted as usize, m + extra_steps);
    assert!(times.iter().all(|t| f.t.contains(t)));
    // a derivative that overflows with one row's input: inside a run, at its edges
    for bad in [5, 16, 17, 2060, 2079, 2080, 4200, 6000, n - 3] {
        let v_bad = c.values(bad).unwrap()[0];
        let g = model!(|_t, x: [S; 3], u: [2]| vector![
            x[2].cos() * u[0] * if u[0] == v_bad { 1e308 } else { 1.0 } * 1e10,
            x[2].sin() * u[0],
            x[0] * 0.0 + u[1]
        ]);
        let q = Problem::new(&g, x0, (0.0, t_end)).controls(c.clone());
        let fast = q.solve(Euler, &opts).unwrap_err();
        let general = with_idle_event(&q).solve(Euler, &opts).unwrap_err();
        assert_eq!(fast, general);
        assert!(matches!(fast, Error::NonFinite { component: 0, .. }), "{fast}");
    }
}

/// A log off the step's grid goes through the grid loop a stretch of stops at a time
/// (16, then 32, 64, …): logs whose last stop ends a stretch, or falls just before or
/// after its end, with stops closer than `t − t0` resolves (landed on without a step)
/// at every place, the ends of stretches among them: bit for bit the general path's.
#[test]
fn stretches_of_a_log_off_the_grid_ending_anywhere_are_the_general_paths() {
    let sys = unicycle::model();
    let t0 = -1000.0;
    for n in 1..130 {
        for twins in [2, 3, usize::MAX] {
            // (`s − t0` is mostly the same for `s` and the next float up: one is landed on)
            let mut times = vec![t0];
            for j in 0..n {
                let s = j as f64 * 0.37;
                times.push(s);
                if j % twins == 1 {
                    times.push(s.next_up());
                }
            }
            if n > 1 && twins < usize::MAX {
                assert!(times[3] > times[2] && times[2] - t0 == times[3] - t0);
            }
            let values: Vec<Vec<f64>> = (0..times.len())
                .map(|k| vec![1.0 + 0.1 * k as f64, 0.3 - 0.01 * k as f64])
                .collect();
            let c = Controls::new(times.clone(), values).unwrap();
            let t_end = times[times.len() - 1] + 0.2;
            let p = Problem::new(&sys, vector![0.1, -0.2, 0.3], (t0, t_end)).controls(c);
            for opts in [
                Options::default().fixed(0.5),
                Options::default().fixed(0.5).breakpoints([-3.0]),
            ] {
                let (f, g, s) = both(&p, Euler, &opts);
                same(&f, &g);
                assert_eq!(s.len(), f.t.len());
                assert!(s.iter().zip(&f.x).all(|(a, b)| a.1 == *b));
                assert_eq!(f.last().0, t_end);
            }
        }
    }
}

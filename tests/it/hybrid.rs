//! Events with actions: resets of the state and of the held inputs (hybrid systems),
//! stopping at the n-th occurrence, Zeno executions; against closed forms.

use nalgebra::{DVector, SVector, vector};
use reckon::methods::{Auto, Bdf, Euler, ExponentialEuler, ImplicitEuler, Method, Rk45, Rodas5P};
use reckon::{Controls, Direction, Error, Event, LinearSolver, Options, Problem, Save, Solution, model};

const G: f64 = 9.81;

/// A ball dropped from `h0` at rest, bouncing with restitution `e`: the k-th impact
/// (k = 1, 2, …) is at `t₁ + Σ_{j<k} 2eʲv₁/g`, `t₁ = √(2h₀/g)`, `v₁ = g·t₁`; after it
/// the ball rises at `eᵏv₁` to the apex `(eᵏv₁)²/(2g)` at `t_k + eᵏv₁/g`.
struct Ball {
    h0: f64,
    e: f64,
}

impl Ball {
    fn t1(&self) -> f64 {
        (2.0 * self.h0 / G).sqrt()
    }
    fn v(&self, k: usize) -> f64 {
        self.e.powi(k as i32) * G * self.t1()
    }
    fn impact(&self, k: usize) -> f64 {
        self.t1() + (1..k).map(|j| 2.0 * self.v(j) / G).sum::<f64>()
    }
    fn apex(&self, k: usize) -> (f64, f64) {
        (self.impact(k) + self.v(k) / G, self.v(k).powi(2) / (2.0 * G))
    }
    /// The accumulation time of the impacts, `t₁(1 + 2e/(1 − e))`.
    fn t_inf(&self) -> f64 {
        self.t1() * (1.0 + 2.0 * self.e / (1.0 - self.e))
    }
    fn solve<M: Method<nalgebra::U2>>(&self, m: M, o: &Options, t_end: f64) -> reckon::Result<Solution<nalgebra::U2>> {
        let f = model!(|_t, x: [S; 2]| vector![x[1], S::from(-G)]);
        let e = self.e;
        let impact = Event::new(|_t, x: &SVector<f64, 2>| x[0])
            .direction(Direction::Falling)
            .reset(move |_t, x| vector![x[0], -e * x[1]]);
        let apex = Event::new(|_t, x: &SVector<f64, 2>| x[1]).direction(Direction::Falling);
        Problem::new(&f, vector![self.h0, 0.0], (0.0, t_end))
            .event(impact)
            .event(apex)
            .solve(m, o)
    }
}

/// Worst errors of the impact times, apex times and apex heights over the first `n` bounces.
fn ball_errors(ball: &Ball, sol: &Solution<nalgebra::U2>, n: usize) -> (f64, f64, f64) {
    let impacts: Vec<_> = sol.events.iter().filter(|h| h.index == 0).collect();
    let apexes: Vec<_> = sol.events.iter().filter(|h| h.index == 1).collect();
    assert!(
        impacts.len() >= n && apexes.len() >= n,
        "{} impacts, {} apexes",
        impacts.len(),
        apexes.len()
    );
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for k in 1..=n {
        worst.0 = worst.0.max((impacts[k - 1].t - ball.impact(k)).abs());
        let (ta, ha) = ball.apex(k);
        worst.1 = worst.1.max((apexes[k - 1].t - ta).abs());
        worst.2 = worst.2.max((apexes[k - 1].x[0] - ha).abs());
    }
    worst
}

/// 20 bounces: impact times, apex times and heights against the closed form to 1e-10
/// with RK45, BDF and Rodas5P; every reset is `v⁺ = −e·v⁻` of the state before it, and
/// the solution keeps both states at the impact's time.
#[test]
fn bouncing_ball_against_the_closed_form() {
    let ball = Ball { h0: 10.0, e: 0.9 };
    let n = 20;
    let t_end = ball.impact(n) + ball.v(n) / G; // the 20th apex
    let o = Options::default().rtol(1e-12).atol(1e-12);
    let sols = [
        ("rk45", ball.solve(Rk45, &o, t_end).unwrap()),
        ("bdf", ball.solve(Bdf::default(), &o, t_end).unwrap()),
        ("rodas5p", ball.solve(Rodas5P, &o, t_end).unwrap()),
    ];
    for (name, sol) in &sols {
        let (ti, ta, ha) = ball_errors(&ball, sol, n - 1);
        println!(
            "{name}: {} steps, errors: impacts {ti:.1e}, apex times {ta:.1e}, heights {ha:.1e}",
            sol.stats.accepted
        );
        assert!(ti < 1e-10 && ha < 1e-10, "{name}: impact {ti:e}, apex height {ha:e}");
        // an apex is a flat zero of nothing: v crosses with slope −g, as sharp as an impact
        assert!(ta < 1e-10, "{name}: apex time {ta:e}");
        let impacts: Vec<_> = sol.events.iter().filter(|h| h.index == 0).collect();
        assert_eq!(impacts.len(), n, "{name}");
        for hit in &impacts {
            let after = hit.x_after.as_ref().expect("a reset records its new state");
            assert_eq!(*after, vector![hit.x[0], -0.9 * hit.x[1]]);
            // placed where g has not crossed yet: the ball is not below the floor
            assert!(hit.x[0] >= 0.0, "{name}: impact at height {:e}", hit.x[0]);
            // both states kept, at the same time
            let i = sol
                .t
                .iter()
                .position(|&t| t == hit.t)
                .expect("the impact's time is kept");
            assert_eq!((sol.t[i + 1], sol.x[i], sol.x[i + 1]), (hit.t, hit.x, *after), "{name}");
        }
        // apexes carry no reset
        assert!(sol.events.iter().filter(|h| h.index == 1).all(|h| h.x_after.is_none()));
        assert!((sol.last().0 - t_end).abs() < 1e-12);
    }
}

/// Every method, at loose tolerances and with fixed steps, resets and restarts: the first
/// five impact times are as good as the method's accuracy, never a bounce lost or
/// doubled.
#[test]
fn every_method_bounces_at_loose_tolerances() {
    let ball = Ball { h0: 1.0, e: 0.8 };
    let n = 5;
    let t_end = ball.impact(n) + 0.5 * ball.v(n) / G;
    let check = |name: &str, sol: &Solution<nalgebra::U2>, bound: f64| {
        let impacts: Vec<f64> = sol.events.iter().filter(|h| h.index == 0).map(|h| h.t).collect();
        assert_eq!(impacts.len(), n, "{name}: impacts {impacts:?}");
        let worst = (1..=n)
            .map(|k| (impacts[k - 1] - ball.impact(k)).abs())
            .fold(0.0, f64::max);
        println!(
            "{name}: worst impact-time error {worst:.1e} (bound {bound:e}), {} steps",
            sol.stats.accepted
        );
        assert!(worst < bound, "{name}: {worst:e}");
    };
    for rtol in [1e-1, 1e-2, 1e-3] {
        let o = Options::default().rtol(rtol).atol(rtol * 1e-3);
        // RK45 and Rodas5P integrate the parabola exactly at any step; BDF's first step
        // after each reset is implicit Euler's
        check(&format!("rk45 {rtol:e}"), &ball.solve(Rk45, &o, t_end).unwrap(), 1e-12);
        check(
            &format!("rodas5p {rtol:e}"),
            &ball.solve(Rodas5P, &o, t_end).unwrap(),
            1e-12,
        );
        check(
            &format!("bdf {rtol:e}"),
            &ball.solve(Bdf::default(), &o, t_end).unwrap(),
            10.0 * rtol,
        );
        check(
            &format!("auto {rtol:e}"),
            &ball.solve(Auto::default(), &o, t_end).unwrap(),
            1e-12,
        );
        check(
            &format!("implicit euler {rtol:e}"),
            &ball.solve(ImplicitEuler::default(), &o, t_end).unwrap(),
            10.0 * rtol,
        );
    }
    // fixed steps: first order, the parabola's error O(h)
    let h = 1e-3;
    let fixed = Options::default().fixed(h);
    check("euler h=1e-3", &ball.solve(Euler, &fixed, t_end).unwrap(), 20.0 * h);
    check(
        "implicit euler h=1e-3",
        &ball.solve(ImplicitEuler::default(), &fixed, t_end).unwrap(),
        20.0 * h,
    );
    // exponential Euler is exact on this linear model
    check(
        "exponential euler h=0.05",
        &ball
            .solve(ExponentialEuler, &Options::default().fixed(0.05), t_end)
            .unwrap(),
        1e-12,
    );
}

/// Restitution 0.5: the impacts accumulate at `t∞ = 3·t₁`. Past it is a typed Zeno
/// error close to `t∞`, with every method, not a hang and not a ball through the floor.
#[test]
fn zeno_ball_ends_in_a_typed_error_at_the_accumulation_time() {
    let ball = Ball { h0: 1.0, e: 0.5 };
    let t_inf = ball.t_inf();
    let o = Options::default().rtol(1e-10).atol(1e-12);
    for (name, r) in [
        ("rk45", ball.solve(Rk45, &o, 2.0 * t_inf)),
        ("bdf", ball.solve(Bdf::default(), &o, 2.0 * t_inf)),
        ("rodas5p", ball.solve(Rodas5P, &o, 2.0 * t_inf)),
    ] {
        match r {
            Err(Error::Zeno { t, count, window }) => {
                println!(
                    "{name}: Zeno at t∞ − {:.1e}: {count} resets within {window:.1e}",
                    t_inf - t
                );
                assert!(t <= t_inf + 1e-12 && t_inf - t < 1e-7, "{name}: t = {t}, t∞ = {t_inf}");
            }
            other => panic!("{name}: {other:?}"),
        }
    }
    // a laxer limit is the user's to set: 3 resets within 10⁻³ of the span
    match ball.solve(Rk45, &o.clone().zeno(3, 1e-3), 2.0 * t_inf) {
        Err(Error::Zeno { t, count: 3, .. }) => assert!(t_inf - t < 1e-2 && t < t_inf),
        other => panic!("{other:?}"),
    }
    let e = ball.solve(Rk45, &o, 2.0 * t_inf).unwrap_err();
    assert!(e.to_string().contains("Options::zeno"), "{e}");
    assert!(ball.solve(Rk45, &o.clone().zeno(1, 1e-9), 1.0).is_err());
}

/// A thermostat with hysteresis, `T' = −a(T − T_a) + b·u`: the heater (u = 1) switches off
/// where T rises to T_high and on where it falls to T_low, by resets of the held input.
/// Heating takes `ln((T_eq − T_low)/(T_eq − T_high))/a` (`T_eq = T_a + b/a`), cooling
/// `ln((T_high − T_a)/(T_low − T_a))/a`.
#[test]
fn thermostat_switching_times_against_the_closed_form() {
    let (a, b, t_amb, lo, hi): (f64, f64, f64, f64, f64) = (0.1, 2.0, 10.0, 19.0, 21.0);
    let f = model!(|_t, x: [S; 1], u: [1]| vector![S::from(-a) * (x[0].clone() - S::from(t_amb)) + S::from(b * u[0])]);
    let t_eq = t_amb + b / a;
    let heat = ((t_eq - lo) / (t_eq - hi)).ln() / a;
    let cool = ((hi - t_amb) / (lo - t_amb)).ln() / a;
    let off = Event::new(move |_t, x: &SVector<f64, 1>| x[0] - hi)
        .direction(Direction::Rising)
        .reset_with_inputs(|_t, x, u| {
            u[0] = 0.0;
            *x
        });
    let on = Event::new(move |_t, x: &SVector<f64, 1>| x[0] - lo)
        .direction(Direction::Falling)
        .reset_with_inputs(|_t, x, u| {
            u[0] = 1.0;
            *x
        });
    let cycles = 10;
    let t_end = cycles as f64 * (heat + cool) + 0.5 * heat;
    let p = Problem::new(&f, vector![lo], (0.0, t_end))
        .inputs(vec![1.0])
        .event(off)
        .event(on);
    for (name, sol) in [
        (
            "rk45",
            p.solve(Rk45, &Options::default().rtol(1e-11).atol(1e-11)).unwrap(),
        ),
        (
            "rodas5p",
            p.solve(Rodas5P, &Options::default().rtol(1e-11).atol(1e-11)).unwrap(),
        ),
    ] {
        assert_eq!(sol.events.len(), 2 * cycles, "{name}");
        let mut worst = 0.0f64;
        for (k, hit) in sol.events.iter().enumerate() {
            // off at heat, on at heat + cool, off at 2·heat + cool, …
            let expect = (k / 2 + 1) as f64 * heat + k.div_ceil(2) as f64 * cool;
            assert_eq!(hit.index, k % 2, "{name}: alternating");
            worst = worst.max((hit.t - expect).abs());
            let level = if k % 2 == 0 { hi } else { lo };
            assert!((hit.x[0] - level).abs() < 1e-9, "{name}: switched at T = {}", hit.x[0]);
        }
        println!("{name}: worst switching-time error {worst:.1e} over {cycles} cycles");
        assert!(worst < 1e-8, "{name}: {worst:e}");
        // the temperature stays in the band
        assert!(sol.x.iter().all(|x| x[0] > lo - 1e-8 && x[0] < hi + 1e-8));
    }
}

/// Stop at the n-th occurrence; the direction filter; simultaneous zeros in the order
/// the events were given.
#[test]
fn terminal_after_n_and_directions() {
    // x = sin t: rising zeros at 0 (not a crossing: g starts at 0), 2π, 4π; falling at π, 3π
    let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    let o = Options::default().rtol(1e-11).atol(1e-13);
    let pi = std::f64::consts::PI;
    let rising = Event::new(|_t, x: &SVector<f64, 2>| x[0])
        .direction(Direction::Rising)
        .terminal_after(2);
    let falling = Event::new(|_t, x: &SVector<f64, 2>| x[0]).direction(Direction::Falling);
    let sol = Problem::new(&f, vector![0.0, 1.0], (0.0, 20.0))
        .event(rising)
        .event(falling)
        .solve(Rk45, &o)
        .unwrap();
    let got: Vec<(usize, f64)> = sol.events.iter().map(|h| (h.index, h.t)).collect();
    let want = [(1, pi), (0, 2.0 * pi), (1, 3.0 * pi), (0, 4.0 * pi)];
    assert_eq!(got.len(), want.len(), "{got:?}");
    for ((i, t), (wi, wt)) in got.iter().zip(want) {
        assert_eq!(*i, wi);
        assert!((t - wt).abs() < 1e-9, "{t} against {wt}");
    }
    assert!((sol.last().0 - 4.0 * pi).abs() < 1e-9);
    assert!(sol.events.iter().all(|h| h.x_after.is_none()));
    // two events on the same zero: both recorded, in the order given, and the reset of
    // the second acts after the first was recorded
    let a = Event::new(|_t, x: &SVector<f64, 2>| x[0]).direction(Direction::Falling);
    let b = Event::new(|_t, x: &SVector<f64, 2>| x[0])
        .direction(Direction::Falling)
        .reset(|_t, x| vector![x[0], 0.0]);
    let sol = Problem::new(&f, vector![0.0, 1.0], (0.0, 4.0))
        .event(a)
        .event(b)
        .solve(Rk45, &o)
        .unwrap();
    assert_eq!(sol.events.iter().map(|h| h.index).collect::<Vec<_>>(), [0, 1]);
    assert_eq!(sol.events[0].t, sol.events[1].t);
    // stopped at rest at the origin (up to the reset's rounding): stays there
    assert!(sol.last().1.norm() < 1e-9, "{}", sol.last().1);
}

/// A reset of the held inputs holds until the next row of a control table, which then
/// takes over; with `Save::At` the output times on either side read the right branch.
#[test]
fn reset_of_inputs_with_controls_and_output_times() {
    // x' = u: the table says u = 1 on [0, 2), u = 3 on [2, 4]; an event where x rises
    // through 1 sets u = −1 (until the table's next row)
    let f = model!(|_t, x: [S; 1], u: [1]| vector![S::from(u[0])]);
    let c = Controls::new(vec![0.0, 2.0], vec![vec![1.0], vec![3.0]]).unwrap();
    let ev = Event::new(|_t, x: &SVector<f64, 1>| x[0] - 1.0)
        .direction(Direction::Rising)
        .reset_with_inputs(|_t, x, u| {
            u[0] = -1.0;
            *x
        });
    let p = Problem::new(&f, vector![0.0], (0.0, 4.0)).controls(c).event(ev);
    // x = t to 1, then 2 − t to t = 2 (x = 0), then 3(t − 2) up to 1 at t = 7/3, where
    // the event fires again: 1 − (t − 7/3) after it
    let at = Save::At(vec![0.5, 1.5, 2.2, 3.0, 4.0]);
    for (name, sol) in [
        ("rk45", p.solve(Rk45, &Options::default().save(at.clone())).unwrap()),
        (
            "bdf",
            p.solve(Bdf::default(), &Options::default().rtol(1e-10).save(at.clone()))
                .unwrap(),
        ),
    ] {
        assert_eq!(sol.t, [0.5, 1.5, 2.2, 3.0, 4.0], "{name}");
        let want = [0.5, 0.5, 0.6, 1.0 / 3.0, -2.0 / 3.0];
        for (x, w) in sol.x.iter().zip(want) {
            assert!((x[0] - w).abs() < 1e-8, "{name}: {} against {w}", x[0]);
        }
        let times: Vec<f64> = sol.events.iter().map(|h| h.t).collect();
        assert_eq!(times.len(), 2, "{name}: {times:?}");
        assert!(
            (times[0] - 1.0).abs() < 1e-10 && (times[1] - 7.0 / 3.0).abs() < 1e-10,
            "{name}: {times:?}"
        );
    }
}

/// The streaming driver: `step_until` across resets, `Integrator::events` as they come.
#[test]
fn streaming_driver_resets() {
    let ball = Ball { h0: 1.0, e: 0.8 };
    let f = model!(|_t, x: [S; 2]| vector![x[1], S::from(-G)]);
    let impact = Event::new(|_t, x: &SVector<f64, 2>| x[0])
        .direction(Direction::Falling)
        .reset(|_t, x| vector![x[0], -0.8 * x[1]]);
    let p = Problem::new(&f, vector![1.0, 0.0], (0.0, f64::INFINITY)).event(impact);
    let mut it = p.integrator(Rk45, &Options::default().rtol(1e-12).atol(1e-12)).unwrap();
    let mut seen = 0;
    for k in 1..=40 {
        let t_stop = 0.1 * k as f64;
        while !it.reached(t_stop) {
            it.step_until(t_stop).unwrap();
        }
        // the state follows the closed form between impacts
        let n = it.events().len();
        let (tk, vk) = if n == 0 {
            (0.0, 0.0)
        } else {
            (ball.impact(n), ball.v(n))
        };
        let s = t_stop - tk;
        let x = if n == 0 {
            1.0 - 0.5 * G * s * s
        } else {
            vk * s - 0.5 * G * s * s
        };
        assert!((it.x()[0] - x).abs() < 1e-9, "t = {t_stop}: {} against {x}", it.x()[0]);
        seen = n;
    }
    assert_eq!(seen, (1..).take_while(|&k| ball.impact(k) < 4.0).count());
}

/// Events and resets on a traced sparse model: the 1-D Brusselator (1 000 states) with
/// BDF on the sparse LU stops where `u₁` first crosses a level, and a reset that
/// changes nothing leaves the solution as the run without the event (to the tolerance).
#[test]
fn events_on_a_sparse_stiff_model() {
    let n = 500;
    let sys = reckon::studies::problems::brusselator(n);
    let x0 = reckon::studies::problems::brusselator_y0(n);
    let o = Options::default()
        .rtol(1e-8)
        .atol(1e-8)
        .linear_solver(LinearSolver::Sparse)
        .save(Save::End);
    let plain = Problem::new(&sys, x0.clone(), (0.0, 10.0))
        .solve(Bdf::default(), &o)
        .unwrap();
    // a level u₁ must cross (an odd number of times) between its start and its end
    let level = 0.5 * (x0[0] + plain.last().1[0]);
    let stop = Event::new(move |_t, x: &DVector<f64>| x[0] - level).terminal_after(1);
    let stopped = Problem::new(&sys, x0.clone(), (0.0, 10.0))
        .event(stop)
        .solve(Bdf::default(), &o)
        .unwrap();
    let te = stopped.last().0;
    assert_eq!(stopped.events.len(), 1);
    assert!(
        (stopped.last().1[0] - level).abs() < 1e-9,
        "{} against {level}",
        stopped.last().1[0]
    );
    // the same time from the plain run's dense output
    let dense = Problem::new(&sys, x0.clone(), (0.0, 10.0))
        .solve(Bdf::default(), &o.clone().dense(true))
        .unwrap();
    assert!(
        (dense.at(te).unwrap()[0] - level).abs() < 1e-6,
        "{}",
        dense.at(te).unwrap()[0]
    );
    let identity = Event::new(move |_t, x: &DVector<f64>| x[0] - level).reset(|_t, x| x.clone());
    let reset = Problem::new(&sys, x0.clone(), (0.0, 10.0))
        .event(identity)
        .solve(Bdf::default(), &o)
        .unwrap();
    let diff = (reset.last().1 - plain.last().1).amax();
    println!(
        "brusselator: u₁ = {level:.4} at t = {te:.6}; {} identity resets change x(10) by {diff:.1e}",
        reset.events.len()
    );
    assert!(diff < 1e-5, "{diff:e}");
    // a reset map returning the wrong length is a typed error, not a panic
    let short = Event::new(move |_t, x: &DVector<f64>| x[0] - level).reset(|_t, x| x.rows(0, 3).into_owned());
    match Problem::new(&sys, x0, (0.0, 10.0))
        .event(short)
        .solve(Bdf::default(), &o)
    {
        Err(Error::EventReset { index: 0, reason, .. }) => assert!(reason.contains("3 components"), "{reason}"),
        other => panic!("{other:?}"),
    }
}

/// A reset to a non-finite state is [`Error::EventReset`]; sensitivities refuse events.
#[test]
fn bad_resets_are_typed_errors() {
    let f = model!(|_t, x: [S; 2]| vector![x[1], S::from(-G)]);
    let nan = Event::new(|_t, x: &SVector<f64, 2>| x[0])
        .direction(Direction::Falling)
        .reset(|_t, x| vector![x[0], f64::NAN]);
    match Problem::new(&f, vector![1.0, 0.0], (0.0, 2.0))
        .event(nan)
        .solve(Rk45, &Options::default())
    {
        Err(Error::EventReset { index: 0, t, reason }) => {
            assert!((t - (2.0 / G).sqrt()).abs() < 1e-6);
            assert!(reason.contains("component 1"), "{reason}");
        }
        other => panic!("{other:?}"),
    }
    let g = model!(|_t, x: [S; 1], u: [1]| vector![S::from(u[0])]);
    let bad_u = Event::new(|_t, x: &SVector<f64, 1>| x[0] - 0.5).reset_with_inputs(|_t, x, u| {
        u[0] = f64::INFINITY;
        *x
    });
    let e = Problem::new(&g, vector![0.0], (0.0, 1.0))
        .inputs(vec![1.0])
        .event(bad_u)
        .solve(Rk45, &Options::default())
        .unwrap_err();
    assert!(
        matches!(e, Error::EventReset { .. }) && e.to_string().contains("held input 0"),
        "{e}"
    );
}

/// A reset that leaves the crossing motion alone (a lap counter: `n ← n + 1` where
/// `x = sin t` crosses zero) counts each crossing once: zeros at π, 2π, 3π give n = 3,
/// with RK45 and BDF, where a reset placed before the zero would otherwise see the same
/// crossing again on the next step.
#[test]
fn a_counter_reset_counts_each_crossing_once() {
    let f = model!(|_t, x: [S; 3]| vector![x[1].clone(), -x[0].clone(), S::from(0.0)]);
    let lap = Event::new(|_t, x: &SVector<f64, 3>| x[0]).reset(|_t, x| vector![x[0], x[1], x[2] + 1.0]);
    let p = Problem::new(&f, vector![0.0, 1.0, 0.0], (0.0, 10.0)).event(lap);
    let o = Options::default().rtol(1e-10).atol(1e-12);
    for (name, sol) in [
        ("rk45", p.solve(Rk45, &o).unwrap()),
        ("bdf", p.solve(Bdf::default(), &o).unwrap()),
    ] {
        let times: Vec<f64> = sol.events.iter().map(|h| h.t).collect();
        assert_eq!(times.len(), 3, "{name}: {times:?}");
        for (k, t) in times.iter().enumerate() {
            assert!(
                (t - (k + 1) as f64 * std::f64::consts::PI).abs() < 1e-8,
                "{name}: {times:?}"
            );
        }
        assert_eq!(sol.last().1[2], 3.0, "{name}");
        assert!(
            (sol.last().1[0] - 10f64.sin()).abs() < 1e-7,
            "{name}: {}",
            sol.last().1[0]
        );
    }
}

/// Sensitivities across a bounce: the saltation matrix. The ball from `(h₀, v₀)` hits the
/// floor at `τ = (v₀ + √(v₀² + 2gh₀))/g` and leaves at `v⁺ = −e·(v₀ − gτ)`; between the
/// first two impacts the state is a closed form in `(h₀, v₀)`, whose derivatives (central
/// differences of the closed form, error ~1e-10) `∂x(t)/∂x₀` must match, with RK45 and
/// BDF. Without the saltation update the columns would be off by O(1).
#[test]
fn sensitivities_across_a_bounce_take_the_saltation_matrix() {
    use reckon::sensitivity::{self, SensitivityOptions};
    let e = 0.8;
    let closed = |h0: f64, v0: f64, t: f64| {
        let tau = (v0 + (v0 * v0 + 2.0 * G * h0).sqrt()) / G;
        let vp = -e * (v0 - G * tau);
        let s = t - tau;
        vector![vp * s - 0.5 * G * s * s, vp - G * s]
    };
    let (h0, v0, t_end) = (1.0, 0.5, 0.9);
    let f = model!(|_t, x: [S; 2]| vector![x[1].clone(), S::from(-G)]);
    let bounce = || {
        Event::new(|_t, x: &SVector<f64, 2>| x[0])
            .direction(Direction::Falling)
            .reset(move |_t, x| vector![x[0], -e * x[1]])
    };
    let p = Problem::new(&f, vector![h0, v0], (0.0, t_end)).event(bounce());
    let o = Options::default().rtol(1e-11).atol(1e-12);
    let d = 1e-5;
    let fd = |j: usize| {
        let (dh, dv) = if j == 0 { (d, 0.0) } else { (0.0, d) };
        (closed(h0 + dh, v0 + dv, t_end) - closed(h0 - dh, v0 - dv, t_end)) / (2.0 * d)
    };
    let want = nalgebra::Matrix2::from_columns(&[fd(0), fd(1)]);
    for (name, s) in [
        (
            "rk45",
            sensitivity::solve(&p, Rk45, &o, &SensitivityOptions::default()).unwrap(),
        ),
        (
            "bdf",
            sensitivity::solve(&p, Bdf::default(), &o, &SensitivityOptions::default()).unwrap(),
        ),
    ] {
        let k = s.t.len() - 1;
        let got = s.wrt_x0(k);
        let err = (&got - want).amax();
        println!("{name}: ∂x/∂x₀ after a bounce {got:.6}, closed form {want:.6}, error {err:.1e}");
        assert!((s.last_x() - closed(h0, v0, t_end)).amax() < 1e-9, "{name}: state");
        assert!(err < 1e-6, "{name}: {err:e}");
    }
    // a terminal event is refused (its stop time's sensitivity is not applied)
    let stop =
        Problem::new(&f, vector![h0, v0], (0.0, t_end)).event(Event::new(|_t, x: &SVector<f64, 2>| x[0]).terminal());
    assert!(sensitivity::solve(&stop, Rk45, &o, &SensitivityOptions::default()).is_err());
}

/// An exact flow with resets, and a reset that leaves the state on the event's surface:
/// the unicycle drives along x at 1 m/s; where x crosses 1 a reset turns it by π/2, onto
/// the line x = 1 itself (in f64, cos(π/2) = 6e-17, so rounding alone would carry it
/// across again); at t = 2 it turns back (heading π), at t = 2.5 forward (heading 0), and
/// at t = 3 it crosses x = 1 again, for real: (1, 1.5) heading along y at t = 3.5. The
/// flow is exact, so only the events' locations limit the answer.
#[test]
fn exact_flow_with_resets_onto_the_surface() {
    use reckon::methods::Exact;
    use reckon::vehicles::unicycle;
    use std::f64::consts::{FRAC_PI_2, PI};
    let turn = Event::new(|_t, x: &SVector<f64, 3>| x[0] - 1.0)
        .direction(Direction::Rising)
        .reset(|_t, x| vector![x[0], x[1], x[2] + FRAC_PI_2]);
    let back = Event::new(|t, _x: &SVector<f64, 3>| t - 2.0).reset(|_t, x| vector![x[0], x[1], PI]);
    let forth = Event::new(|t, _x: &SVector<f64, 3>| t - 2.5).reset(|_t, x| vector![x[0], x[1], 0.0]);
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 3.5))
        .inputs(vec![1.0, 0.0])
        .event(turn)
        .event(back)
        .event(forth);
    let sol = p
        .solve(Exact::new(unicycle::flow), &Options::default().rtol(1e-10).atol(1e-12))
        .unwrap();
    let hits: Vec<(usize, f64)> = sol.events.iter().map(|e| (e.index, e.t)).collect();
    assert_eq!(hits.iter().map(|h| h.0).collect::<Vec<_>>(), [0, 1, 2, 0], "{hits:?}");
    for ((_, t), want) in hits.iter().zip([1.0, 2.0, 2.5, 3.0]) {
        assert!((t - want).abs() < 1e-12, "{hits:?}");
    }
    let x = sol.last().1;
    let want = vector![1.0, 1.5, FRAC_PI_2];
    assert!((x - want).amax() < 1e-12, "{x} against {want}");
}

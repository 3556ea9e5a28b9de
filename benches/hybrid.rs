//! Issue 36: the cost of a reset against a plain step. An oscillator `x = sin t` on
//! `[0, 200]` with an event on `x = 0` (63 crossings): recorded only, or resetting a lap
//! counter `n ← n + 1` (the same trajectory, but each reset restarts the method: its
//! carried stage or history dropped, Hairer's first step chosen again). The difference per
//! crossing is the reset's cost, printed with the plain run's time per step to state it in
//! steps. RK45 and BDF at rtol 1e-8, one criterion group per method (interleaved). Then
//! the saltation update's cost ([`saltation`]).

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{SVector, vector};
use reckon::methods::{Bdf, Method, Rk45};
use reckon::{Event, Options, Problem, Save, model};
use std::hint::black_box;
use std::time::{Duration, Instant};

const T_END: f64 = 200.0;

fn solve<M: Method<nalgebra::U3> + Clone>(m: M, reset: bool) -> (u64, usize) {
    let f = model!(|_t, x: [S; 3]| vector![x[1].clone(), -x[0].clone(), S::from(0.0)]);
    let g = |_t: f64, x: &SVector<f64, 3>| x[0];
    let ev = if reset {
        Event::new(g).reset(|_t, x| vector![x[0], x[1], x[2] + 1.0])
    } else {
        Event::new(g)
    };
    let o = Options::default().rtol(1e-8).atol(1e-10).save(Save::End);
    let s = Problem::new(&f, vector![0.0, 1.0, 0.0], (0.0, T_END))
        .event(ev)
        .solve(m, &o)
        .unwrap();
    (s.stats.accepted, s.events.len())
}

fn group<M: Method<nalgebra::U3> + Clone>(c: &mut Criterion, name: &str, m: M) {
    // a first look: steps, crossings, and CPU time per solve of each (100 solves)
    let per = |reset: bool| {
        let t = Instant::now();
        for _ in 0..100 {
            black_box(solve(m.clone(), reset));
        }
        t.elapsed().as_secs_f64() / 100.0
    };
    let (plain, resets) = (solve(m.clone(), false), solve(m.clone(), true));
    let (tp, tr) = (per(false), per(true));
    let n = resets.1 as f64;
    eprintln!(
        "hybrid/{name}: plain {} steps {:.1} µs ({:.2} µs/step); reset {} steps {:.1} µs; per reset {:.2} µs = {:.1} plain steps, {:.1} extra steps",
        plain.0,
        tp * 1e6,
        tp * 1e6 / plain.0 as f64,
        resets.0,
        tr * 1e6,
        (tr - tp) * 1e6 / n,
        (tr - tp) / n / (tp / plain.0 as f64),
        (resets.0 as f64 - plain.0 as f64) / n
    );
    let mut g = c.benchmark_group(format!("hybrid/{name}"));
    g.warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    g.bench_function("event-recorded", |b| b.iter(|| solve(black_box(m.clone()), false)));
    g.bench_function("event-resets", |b| b.iter(|| solve(black_box(m.clone()), true)));
    g.finish();
}

fn bench(c: &mut Criterion) {
    group(c, "rk45", Rk45);
    group(c, "bdf", Bdf::default());
}

criterion_group!(benches, bench, saltation);
criterion_main!(benches);

/// The saltation update's cost: the bouncing ball's sensitivities `∂x/∂x₀` over 12
/// bounces (RK45, rtol 1e-8) against the same solve without sensitivities; the extra
/// time per bounce beyond the run without resets' sensitivity cost is the update's.
fn saltation(c: &mut Criterion) {
    use reckon::Direction;
    use reckon::sensitivity::{self, SensitivityOptions};
    let f = model!(|_t, x: [S; 2]| vector![x[1].clone(), S::from(-9.81)]);
    let t_end = 6.0;
    let run = |reset: bool, sens: bool| {
        let g = |_t: f64, x: &SVector<f64, 2>| x[0];
        let ev = if reset {
            Event::new(g)
                .direction(Direction::Falling)
                .reset(|_t, x| vector![x[0], -0.8 * x[1]])
        } else {
            Event::new(g).direction(Direction::Falling)
        };
        // without the reset the ball falls through the floor: the same span, no bounces
        let p = Problem::new(&f, vector![10.0, 0.0], (0.0, t_end)).event(ev);
        let o = Options::default().rtol(1e-8).atol(1e-10).save(Save::End);
        if sens {
            let s = sensitivity::solve(&p, Rk45, &o, &SensitivityOptions::default()).unwrap();
            (s.stats.accepted, s.t.len())
        } else {
            let s = p.solve(Rk45, &o).unwrap();
            (s.stats.accepted, s.events.len())
        }
    };
    let bounces = run(true, false).1;
    eprintln!(
        "hybrid/saltation: {bounces} bounces; steps: plain {} / with S {}, resets {} / with S {}",
        run(false, false).0,
        run(false, true).0,
        run(true, false).0,
        run(true, true).0
    );
    let mut g = c.benchmark_group("hybrid/saltation");
    g.warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    g.bench_function("falls-x", |b| b.iter(|| run(black_box(false), false)));
    g.bench_function("falls-x-and-S", |b| b.iter(|| run(black_box(false), true)));
    g.bench_function("bounces-x", |b| b.iter(|| run(black_box(true), false)));
    g.bench_function("bounces-x-and-S", |b| b.iter(|| run(black_box(true), true)));
    g.finish();
}

//! RK45 on Lorenz, Arenstorf and Van der Pol (μ = 1): reckon vs a hand-written
//! Dormand–Prince loop with the same controller vs the `ode_solvers` crate's Dopri5.

mod handwritten;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use ode_solvers as os;
use reckon::methods::Rk45;
use reckon::studies::problems::*;
use reckon::{Options, Problem, System};
use std::hint::black_box;
use std::time::Duration;

/// ode_solvers given the same model code as the hand-written loop: the function item
/// itself (a zero-sized type, so the call inlines), not a function pointer.
struct Os<const N: usize, H>(H);

impl<const N: usize, H: Fn(f64, &[f64; N]) -> [f64; N]> os::System<f64, os::SVector<f64, N>> for Os<N, H> {
    #[inline(always)]
    fn system(&self, t: f64, y: &os::SVector<f64, N>, dy: &mut os::SVector<f64, N>) {
        let r = (self.0)(t, &y.data.0[0]);
        dy.data.0[0] = r;
    }
}

fn ode_solvers_run<const N: usize>(
    f: impl Fn(f64, &[f64; N]) -> [f64; N],
    x0: [f64; N],
    t_end: f64,
    tol: f64,
) -> (f64, u32) {
    let y0 = os::SVector::<f64, N>::from(x0);
    let mut s = os::Dopri5::from_param(
        Os(f),
        0.0,
        t_end,
        0.0,
        y0,
        tol,
        tol,
        0.9,
        0.04,
        0.2,
        10.0,
        t_end,
        0.0,
        100_000,
        1000,
        os::OutputType::Sparse,
    );
    let st = s.integrate().expect("ode_solvers failed");
    (s.y_out().last().map(|y| y[0]).unwrap_or(f64::NAN), st.num_eval)
}

/// `hand` is a function item (not a pointer), so the hand-written loop inlines it.
fn bench_problem<const N: usize, H: Fn(f64, &[f64; N]) -> [f64; N] + Copy>(
    c: &mut Criterion,
    name: &str,
    sys: impl System<nalgebra::Const<N>>,
    hand: H,
    x0: [f64; N],
    t_end: f64,
) {
    let mut g = c.benchmark_group(format!("rk45/{name}"));
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    let p = Problem::new(&sys, nalgebra::SVector::from(x0), (0.0, t_end));
    for tol in [1e-4, 1e-6, 1e-8, 1e-10] {
        let opts = Options::default().rtol(tol).atol(tol).dense(false);
        let r = p.solve(Rk45, &opts).unwrap();
        let h = handwritten::dopri5(hand, 0.0, t_end, x0, tol);
        let (_, os_evals) = ode_solvers_run(hand, x0, t_end, tol);
        eprintln!(
            "{name} tol {tol:e}: rhs evals reckon {} hand-written {} ode_solvers {os_evals}",
            r.stats.rhs_evals, h.evals
        );
        g.bench_with_input(BenchmarkId::new("reckon", tol), &tol, |b, _| {
            b.iter(|| black_box(p.solve(Rk45, black_box(&opts)).unwrap().stats.accepted))
        });
        g.bench_with_input(BenchmarkId::new("hand-written", tol), &tol, |b, &tol| {
            b.iter(|| black_box(handwritten::dopri5(hand, 0.0, t_end, black_box(x0), tol).accepted))
        });
        g.bench_with_input(BenchmarkId::new("ode_solvers", tol), &tol, |b, &tol| {
            b.iter(|| black_box(ode_solvers_run(hand, black_box(x0), t_end, tol)))
        });
    }
    g.finish();
}

fn rk45(c: &mut Criterion) {
    bench_problem(c, "lorenz", lorenz(), handwritten::lorenz, [1.0, 1.0, 1.0], 20.0);
    bench_problem(
        c,
        "arenstorf",
        arenstorf(),
        handwritten::arenstorf,
        ARENSTORF_Y0,
        ARENSTORF_T,
    );
    bench_problem(
        c,
        "vdp1",
        handwritten::van_der_pol_model(),
        handwritten::van_der_pol,
        [2.0, 0.0],
        20.0,
    );
}

/// The model call alone: a `model!` closure through `System::rhs` vs the same body as a
/// plain `fn` over arrays, both writing into a buffer that outlives the call.
fn rhs_call(c: &mut Criterion) {
    let mut g = c.benchmark_group("rhs-call");
    g.sample_size(30)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    let sys = arenstorf();
    let x = arenstorf_y0();
    let mut dx = nalgebra::Vector4::zeros();
    g.bench_function("arenstorf/reckon", |b| {
        b.iter(|| {
            sys.rhs(0.0, black_box(&x), &[], &mut dx);
            black_box(dx)
        })
    });
    let mut out = [0.0; 4];
    g.bench_function("arenstorf/hand-written", |b| {
        b.iter(|| {
            out = handwritten::arenstorf(0.0, black_box(&ARENSTORF_Y0));
            black_box(out)
        })
    });
    let sys = lorenz();
    let x = lorenz_y0();
    let mut dx = nalgebra::Vector3::zeros();
    g.bench_function("lorenz/reckon", |b| {
        b.iter(|| {
            sys.rhs(0.0, black_box(&x), &[], &mut dx);
            black_box(dx)
        })
    });
    let mut out = [0.0; 3];
    g.bench_function("lorenz/hand-written", |b| {
        b.iter(|| {
            out = handwritten::lorenz(0.0, black_box(&[1.0, 1.0, 1.0]));
            black_box(out)
        })
    });
    g.finish();
}

criterion_group!(benches, rk45, rhs_call);
criterion_main!(benches);

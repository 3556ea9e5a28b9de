//! A counting global allocator: a fixed-size step allocates nothing after setup.

use nalgebra::vector;
use reckon::methods::{Bdf, Euler, Exact, ImplicitEuler, Method, Rk45, Rodas5P};
use reckon::studies::problems::{robertson, van_der_pol};
use reckon::vehicles::unicycle;
use reckon::{Controls, Options, Problem, System};
use std::alloc::{GlobalAlloc, Layout, System as Sys};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;
static ALLOCS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::SeqCst);
        unsafe { Sys.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { Sys.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::SeqCst);
        unsafe { Sys.realloc(p, l, n) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by `steps` calls of `step()` after the integrator is set up.
fn allocs_in_steps<const N: usize, S, M>(
    p: &Problem<'_, nalgebra::Const<N>, S>,
    m: M,
    opts: &Options,
    steps: usize,
) -> usize
where
    S: System<nalgebra::Const<N>>,
    M: Method<nalgebra::Const<N>>,
{
    allocs_and_stats(p, m, opts, steps).0
}

fn allocs_and_stats<const N: usize, S, M>(
    p: &Problem<'_, nalgebra::Const<N>, S>,
    m: M,
    opts: &Options,
    steps: usize,
) -> (usize, reckon::Stats)
where
    S: System<nalgebra::Const<N>>,
    M: Method<nalgebra::Const<N>>,
{
    let mut it = p.integrator(m, opts).unwrap();
    it.step().unwrap(); // first step may warm up
    let before = ALLOCS.load(Ordering::SeqCst);
    for _ in 0..steps {
        assert!(it.step().unwrap().is_some(), "ran out of steps");
    }
    (ALLOCS.load(Ordering::SeqCst) - before, it.stats())
}

// One test function: the counter is global, so parallel tests would disturb each other.
#[test]
fn fixed_size_steps_allocate_nothing() {
    let opts = Options::default().dense(false);
    let vdp = Problem::new(van_der_pol(1.0), vector![2.0, 0.0], (0.0, 20.0));
    assert_eq!(
        allocs_in_steps(&vdp, Euler, &opts.clone().fixed(1e-3), 200),
        0,
        "explicit Euler"
    );
    assert_eq!(allocs_in_steps(&vdp, Rk45, &opts, 50), 0, "adaptive RK45");
    assert_eq!(
        allocs_in_steps(&vdp, Rk45, &opts.clone().fixed(0.01), 200),
        0,
        "fixed RK45"
    );
    assert_eq!(
        allocs_in_steps(&vdp, ImplicitEuler::default(), &opts.clone().fixed(0.01), 200),
        0,
        "implicit Euler fixed"
    );
    let rob = Problem::new(robertson(), vector![1.0, 0.0, 0.0], (0.0, 1e5));
    let (n, stats) = allocs_and_stats(
        &rob,
        ImplicitEuler::default().proportional(false),
        &opts.clone().rtol(1e-4).atol(1e-8),
        400,
    );
    assert!(stats.jacobian_evals > 1 && stats.lu_decompositions > 20, "{stats:?}");
    assert_eq!(
        n, 0,
        "adaptive implicit Euler on Robertson (Jacobian refreshes and LU included)"
    );
    let (n, stats) = allocs_and_stats(&rob, Rodas5P, &opts.clone().rtol(1e-6).atol(1e-10), 100);
    assert!(stats.jacobian_evals > 50 && stats.lu_decompositions > 50, "{stats:?}");
    assert_eq!(n, 0, "adaptive Rodas5P on Robertson");
    assert_eq!(
        allocs_in_steps(&vdp, Rodas5P, &opts.clone().fixed(0.01), 200),
        0,
        "Rodas5P fixed"
    );
    let (n, stats) = allocs_and_stats(&rob, Bdf::default(), &opts.clone().rtol(1e-6).atol(1e-10), 100);
    assert!(stats.lu_decompositions > 5 && stats.accepted > 50, "{stats:?}");
    assert_eq!(n, 0, "adaptive BDF on Robertson (order changes, LU refactors)");
    // breakpoints with input changes and the exact flow
    let times: Vec<f64> = (0..=400).map(|k| k as f64 * 0.05).collect();
    let values = times.iter().map(|t| vec![1.0, t.sin()]).collect();
    let c = Controls::new(times, values).unwrap();
    let uni = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 20.0)).controls(c);
    assert_eq!(
        allocs_in_steps(&uni, Exact::new(unicycle::flow), &opts, 200),
        0,
        "exact flow"
    );
    assert_eq!(allocs_in_steps(&uni, Rk45, &opts, 200), 0, "RK45 across breakpoints");
    assert_eq!(
        allocs_in_steps(&uni, ImplicitEuler::default(), &opts.clone().fixed(0.01), 200),
        0,
        "IE across breakpoints"
    );
    assert_eq!(
        allocs_in_steps(&uni, Rodas5P, &opts, 200),
        0,
        "Rodas5P across breakpoints"
    );
}

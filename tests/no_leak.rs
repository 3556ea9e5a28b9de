//! Every byte `solve` allocates is freed: counted by a global allocator of this test
//! binary's own (one test, so no other test allocates at the same time). The lean loop
//! over a control log's rows replaces the held row without testing for owned inputs to
//! free; owned inputs held at its start (set by hand) must not be leaked.

use nalgebra::vector;
use reckon::methods::{Euler, Exact};
use reckon::vehicles::unicycle;
use reckon::{Controls, Options, Problem};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicIsize, Ordering};

struct Counting;

static LIVE: AtomicIsize = AtomicIsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        LIVE.fetch_add(l.size() as isize, Ordering::SeqCst);
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(l.size() as isize, Ordering::SeqCst);
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static A: Counting = Counting;

#[test]
fn solve_frees_what_it_allocates_with_inputs_set_by_hand() {
    let n = 1000;
    let times: Vec<f64> = (0..n).map(|k| k as f64 * 0.01).collect();
    let values = (0..n).map(|k| vec![1.0, 0.1 * (k % 7) as f64]).collect();
    let c = Controls::new(times, values).unwrap();
    let sys = unicycle::model();
    let p = Problem::new(&sys, vector![0.0, 0.0, 0.0], (0.0, n as f64 * 0.01)).controls(c);
    let (euler, exact) = (Options::default().fixed(0.004), Options::default());
    let mut ends = Vec::with_capacity(400);
    let before = LIVE.load(Ordering::SeqCst);
    for round in 0..100 {
        for set in [false, true] {
            let mut it = p.integrator(Exact::new(unicycle::flow), &exact).unwrap();
            it.step().unwrap();
            if set {
                it.set_inputs(&[0.5, round as f64]).unwrap();
            }
            ends.push(*it.solve().unwrap().last().1);
            let mut it = p.integrator(Euler, &euler).unwrap();
            it.step().unwrap();
            if set {
                it.set_inputs(&[0.5, round as f64]).unwrap();
            }
            ends.push(*it.solve().unwrap().last().1);
        }
    }
    assert_eq!(LIVE.load(Ordering::SeqCst), before, "bytes still allocated");
    // (the runs did run: every end state finite, and the inputs set changed them)
    assert!(ends.iter().all(|x| x.iter().all(|v| v.is_finite())));
    assert_ne!(ends[0], ends[2]);
}

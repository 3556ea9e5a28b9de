//! Zero crossings of event functions `g(t, x)`, located on the dense output with
//! argmin's Brent root finder.

use crate::error::{Error, Result};
use crate::problem::solution::horner;
use argmin::core::{CostFunction, Executor};
use argmin::solver::brent::BrentRoot;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Which sign changes of `g` count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Direction {
    /// Both.
    #[default]
    Either,
    /// `g` goes from negative to non-negative.
    Rising,
    /// `g` goes from positive to non-positive.
    Falling,
}

/// An event function `g(t, x)`.
pub type EventFn<'a, D> = Box<dyn Fn(f64, &OVector<f64, D>) -> f64 + 'a>;

/// An event: a zero of `g(t, x)`; a terminal one stops the integration there.
///
/// ```
/// use reckon::{model, Event, Direction, Options, Problem, methods::Rk45};
/// use nalgebra::vector;
/// // a ball thrown up at 10 m/s: lands at t = 2·10/9.81
/// let f = model!(|_t, x: [S; 2]| vector![x[1], S::from(-9.81)]);
/// let ground = Event::new(|_t, x: &nalgebra::SVector<f64, 2>| x[0]).direction(Direction::Falling).terminal();
/// let sol = Problem::new(&f, vector![0.0, 10.0], (0.0, 10.0)).event(ground).solve(Rk45, &Options::default()).unwrap();
/// assert!((sol.last().0 - 20.0 / 9.81).abs() < 1e-12);
/// ```
pub struct Event<'a, D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    pub(crate) g: EventFn<'a, D>,
    pub(crate) direction: Direction,
    pub(crate) terminal: bool,
}

impl<'a, D: Dim> Event<'a, D>
where
    DefaultAllocator: Allocator<D>,
{
    /// An event on the zeros of `g`, either direction, not terminal.
    pub fn new(g: impl Fn(f64, &OVector<f64, D>) -> f64 + 'a) -> Self {
        Event {
            g: Box::new(g),
            direction: Direction::Either,
            terminal: false,
        }
    }
    /// Count only this direction of crossing.
    pub fn direction(mut self, d: Direction) -> Self {
        self.direction = d;
        self
    }
    /// Stop the integration at the first zero.
    pub fn terminal(mut self) -> Self {
        self.terminal = true;
        self
    }

    pub(crate) fn crosses(&self, g0: f64, g1: f64) -> bool {
        let rising = g0 < 0.0 && g1 >= 0.0;
        let falling = g0 > 0.0 && g1 <= 0.0;
        match self.direction {
            Direction::Either => rising || falling,
            Direction::Rising => rising,
            Direction::Falling => falling,
        }
    }
}

struct OnStep<'r, 'a, D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    g: &'r (dyn Fn(f64, &OVector<f64, D>) -> f64 + 'a),
    c: &'r [OVector<f64, D>],
    t0: f64,
    h: f64,
}

impl<D: Dim> CostFunction for OnStep<'_, '_, D>
where
    DefaultAllocator: Allocator<D>,
{
    type Param = f64;
    type Output = f64;
    fn cost(&self, t: &f64) -> std::result::Result<f64, argmin::core::Error> {
        let g = (self.g)(*t, &horner(self.c, (*t - self.t0) / self.h));
        if g.is_nan() {
            return Err(argmin::core::Error::msg(format!("event function is NaN at t = {t}")));
        }
        Ok(g)
    }
}

/// The zero of event `index` inside the step `[t0, t1]` (size `h`) whose dense polynomial is `c`.
pub(crate) fn locate<D: Dim>(
    ev: &Event<'_, D>,
    index: usize,
    c: &[OVector<f64, D>],
    t0: f64,
    h: f64,
    t1: f64,
) -> Result<f64>
where
    DefaultAllocator: Allocator<D>,
{
    let (lo, hi) = (t0.min(t1), t0.max(t1));
    let tol = 2.0 * f64::EPSILON * lo.abs().max(hi.abs()) + f64::MIN_POSITIVE;
    let problem = OnStep { g: &*ev.g, c, t0, h };
    let fail = |reason: String| Error::EventLocation { index, t0, t1, reason };
    let res = Executor::new(problem, BrentRoot::new(lo, hi, tol))
        .configure(|s| s.max_iters(200))
        .run()
        .map_err(|e| fail(e.to_string()))?;
    use argmin::core::{State, TerminationReason, TerminationStatus};
    match res.state.get_termination_status() {
        TerminationStatus::Terminated(TerminationReason::SolverConverged) => {}
        other => return Err(fail(format!("root finder stopped: {other:?}"))),
    }
    // the last iterate, where the bracket closed: `best_param` is the smallest |g| seen,
    // which at a pole (a sign change through ±∞) is an end of the step, not the crossing
    match res.state.param {
        Some(t) if t.is_finite() => Ok(t),
        _ => Err(fail("no finite root returned".into())),
    }
}

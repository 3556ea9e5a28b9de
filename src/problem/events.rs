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

/// A reset map `x⁺ = R(t, x⁻, u)`, which may also change the held inputs `u` in place.
pub type ResetFn<'a, D> = Box<dyn Fn(f64, &OVector<f64, D>, &mut [f64]) -> OVector<f64, D> + 'a>;

/// An event: a zero of `g(t, x)` crossed in the chosen [`Direction`], and what it does.
///
/// Every occurrence is recorded in [`Solution::events`](crate::Solution::events). By
/// default the run continues; [`terminal`](Self::terminal) stops it at the first
/// occurrence, [`terminal_after`](Self::terminal_after) at the n-th, and
/// [`reset`](Self::reset) replaces the state by `R(t, x)` there: a hybrid system.
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
    /// Stop at this occurrence (1 = the first); `None`: never.
    pub(crate) stop_at: Option<u64>,
    pub(crate) reset: Option<ResetFn<'a, D>>,
}

impl<'a, D: Dim> Event<'a, D>
where
    DefaultAllocator: Allocator<D>,
{
    /// An event on the zeros of `g`, either direction, recorded and passed.
    pub fn new(g: impl Fn(f64, &OVector<f64, D>) -> f64 + 'a) -> Self {
        Event {
            g: Box::new(g),
            direction: Direction::Either,
            stop_at: None,
            reset: None,
        }
    }
    /// Count only this direction of crossing.
    pub fn direction(mut self, d: Direction) -> Self {
        self.direction = d;
        self
    }
    /// Stop the integration at the first zero.
    pub fn terminal(self) -> Self {
        self.terminal_after(1)
    }
    /// Stop the integration at the `n`-th zero (`n ≥ 1`; 0 acts as 1). The earlier
    /// ones act as the event says otherwise (recorded, or a reset); at the `n`-th the
    /// run ends with the state before any reset.
    ///
    /// ```
    /// use reckon::{model, Event, Options, Problem, methods::Rk45};
    /// use nalgebra::vector;
    /// // x = sin t: the third zero after t = 0 is at 3π
    /// let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    /// let zero = Event::new(|_t, x: &nalgebra::SVector<f64, 2>| x[0]).terminal_after(3);
    /// let opts = Options::default().rtol(1e-10).atol(1e-12);
    /// let sol = Problem::new(&f, vector![0.0, 1.0], (0.0, 20.0)).event(zero).solve(Rk45, &opts).unwrap();
    /// assert_eq!(sol.events.len(), 3);
    /// assert!((sol.last().0 - 3.0 * std::f64::consts::PI).abs() < 1e-8);
    /// ```
    pub fn terminal_after(mut self, n: u64) -> Self {
        self.stop_at = Some(n.max(1));
        self
    }
    /// At each zero, replace the state by `R(t, x⁻)` and go on: the method restarts
    /// there (its carried stages, history and factorisations dropped, the first step
    /// chosen again), and the solution keeps both `(t, x⁻)` and `(t, x⁺)`. The event
    /// is placed on the side of the zero where `g` has not yet crossed, so that a reset
    /// that turns the motion around (a bounce) starts from where `g` can cross again.
    ///
    /// ```
    /// use reckon::{model, Event, Direction, Options, Problem, methods::Rk45};
    /// use nalgebra::{vector, SVector};
    /// // a ball dropped from 1 m, bouncing with restitution 0.5: the n-th impact is at
    /// // t₁(1 + 2·0.5 + … + 2·0.5ⁿ⁻¹), t₁ = √(2/g); they accumulate at 3·t₁ = 1.35 s (Zeno)
    /// let f = model!(|_t, x: [S; 2]| vector![x[1], S::from(-9.81)]);
    /// let bounce = Event::new(|_t, x: &SVector<f64, 2>| x[0])
    ///     .direction(Direction::Falling)
    ///     .reset(|_t, x| vector![x[0], -0.5 * x[1]]);
    /// let opts = Options::default().rtol(1e-12).atol(1e-12);
    /// let sol = Problem::new(&f, vector![1.0, 0.0], (0.0, 1.2)).event(bounce).solve(Rk45, &opts).unwrap();
    /// let t1 = (2.0 / 9.81f64).sqrt();
    /// assert!((sol.events[2].t - t1 * (1.0 + 1.0 + 0.5)).abs() < 1e-10);
    /// assert!((sol.events[2].x_after.as_ref().unwrap()[1] - 0.125 * 9.81 * t1).abs() < 1e-9);
    /// ```
    pub fn reset(self, r: impl Fn(f64, &OVector<f64, D>) -> OVector<f64, D> + 'a) -> Self {
        self.reset_with_inputs(move |t, x, _u: &mut [f64]| r(t, x))
    }
    /// As [`reset`](Self::reset), and the map may also change the held inputs `u` in
    /// place (a thermostat switching its heater, a controller changing mode). With a
    /// [`Controls`](crate::Controls) table the changed inputs hold until its next row.
    ///
    /// ```
    /// use reckon::{model, Event, Direction, Options, Problem, methods::Rk45};
    /// use nalgebra::{vector, SVector};
    /// // x' = u − x with the input switched from 1 to 0 where x reaches 0.5 (t = ln 2)
    /// let f = model!(|_t, x: [S; 1], u: [1]| vector![S::from(u[0]) - x[0]]);
    /// let off = Event::new(|_t, x: &SVector<f64, 1>| x[0] - 0.5)
    ///     .direction(Direction::Rising)
    ///     .reset_with_inputs(|_t, x, u| {
    ///         u[0] = 0.0;
    ///         *x
    ///     });
    /// let opts = Options::default().rtol(1e-10).atol(1e-12);
    /// let p = Problem::new(&f, vector![0.0], (0.0, 2.0)).inputs(vec![1.0]).event(off);
    /// let sol = p.solve(Rk45, &opts).unwrap();
    /// assert!((sol.events[0].t - 2f64.ln()).abs() < 1e-9);
    /// // then x decays from 0.5: x(2) = 0.5·e^(ln 2 − 2)
    /// assert!((sol.last().1[0] - 0.5 * (2f64.ln() - 2.0).exp()).abs() < 1e-9);
    /// ```
    pub fn reset_with_inputs(mut self, r: impl Fn(f64, &OVector<f64, D>, &mut [f64]) -> OVector<f64, D> + 'a) -> Self {
        self.reset = Some(Box::new(r));
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
    // the polynomial's ends are the step's ends up to rounding: a zero that the rounding
    // moved past an end (g of a few ulps, on a step of 10⁻⁹ near a Zeno point) is at
    // that end, the one where g is nearer zero
    let at = |t: f64| problem.cost(&t).map_err(|e| fail(e.to_string()));
    let (g_lo, g_hi) = (at(lo)?, at(hi)?);
    if g_lo == 0.0 {
        return Ok(lo);
    }
    if g_hi == 0.0 || g_lo.signum() == g_hi.signum() {
        return Ok(if g_hi.abs() <= g_lo.abs() { hi } else { lo });
    }
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

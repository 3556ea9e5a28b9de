//! An initial-value problem: model, initial state, span, held inputs, events; the
//! options of a solve and its solution.

pub mod controls;
pub mod events;
pub mod options;
pub mod solution;

use crate::model::System;
use crate::problem::controls::Controls;
use crate::problem::events::Event;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// An initial-value problem `x' = f(t, x, u)`, `x(t0) = x0`, on `[t0, t_end]`
/// (`t_end < t0` integrates backward; `t_end = ±∞` is open-ended, stepped with
/// [`Integrator::step_until`]), with optional held inputs and events.
///
/// Steps are taken in time measured from `t0`, so epoch timestamps (`t0 = 1.7e9` s or
/// `1.7e12` ms) cost no accuracy in the step sizes; times are reported as given.
///
/// ```
/// use reckon::{model, Problem, Options, methods::Rk45};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]); // harmonic oscillator
/// let sol = Problem::new(&f, vector![1.0, 0.0], (0.0, std::f64::consts::PI))
///     .solve(Rk45, &Options::default().rtol(1e-10).atol(1e-12))
///     .unwrap();
/// assert!((sol.last().1[0] + 1.0).abs() < 1e-9); // cos π = −1
/// ```
pub struct Problem<'a, D: Dim, S>
where
    DefaultAllocator: Allocator<D>,
{
    /// The model.
    pub system: S,
    /// Initial state.
    pub x0: OVector<f64, D>,
    /// Start time.
    pub t0: f64,
    /// End time.
    pub t_end: f64,
    /// Inputs held piecewise constant, if the model reads any.
    pub controls: Option<Controls>,
    /// Inputs held constant from `t0` (instead of a schedule), changed while stepping
    /// with [`Integrator::set_inputs`].
    pub held: Option<Vec<f64>>,
    pub(crate) events: Vec<Event<'a, D>>,
    /// `M` of `M·x' = f(t, x)` (`None`: the identity).
    pub(crate) mass: Option<crate::model::mass::Mass>,
}

impl<'a, D: Dim, S: System<D>> Problem<'a, D, S>
where
    DefaultAllocator: Allocator<D>,
{
    /// `x' = f(t, x)`, `x(span.0) = x0`, integrated to `span.1`.
    pub fn new(system: S, x0: OVector<f64, D>, span: (f64, f64)) -> Self {
        Problem {
            system,
            x0,
            t0: span.0,
            t_end: span.1,
            controls: None,
            held: None,
            events: Vec::new(),
            mass: None,
        }
    }
    /// Solve `M·x' = f(t, x)` with a constant mass matrix `M` ([`Mass`](crate::Mass)),
    /// possibly singular (an index-1 DAE), with [`Bdf`](crate::methods::Bdf) or
    /// [`Rodas5P`](crate::methods::Rodas5P); other methods refuse it.
    pub fn mass(mut self, m: crate::model::mass::Mass) -> Self {
        self.mass = Some(m);
        self
    }
    /// Hold inputs piecewise constant; every control time becomes a breakpoint.
    pub fn controls(mut self, controls: Controls) -> Self {
        self.controls = Some(controls);
        self
    }
    /// Hold `u` from `t0` on, with no schedule: for streaming, where the caller switches
    /// inputs with [`Integrator::set_inputs`] as they arrive.
    ///
    /// ```
    /// use reckon::{methods::Exact, vehicles::unicycle, Options, Problem};
    /// use nalgebra::vector;
    /// let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 3.0)).inputs(vec![2.0, 0.0]);
    /// let sol = p.solve(Exact::new(unicycle::flow), &Options::default()).unwrap();
    /// assert_eq!(*sol.last().1, vector![6.0, 0.0, 0.0]);
    /// ```
    pub fn inputs(mut self, u: Vec<f64>) -> Self {
        self.held = Some(u);
        self
    }
    /// Watch for zeros of an event function.
    pub fn event(mut self, event: Event<'a, D>) -> Self {
        self.events.push(event);
        self
    }
    /// Whether any event is watched.
    pub(crate) fn has_events(&self) -> bool {
        !self.events.is_empty()
    }
}

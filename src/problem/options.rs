//! Integration options: named fields with defaults and chainable setters.

use crate::error::{Error, Result};
use crate::jacobian::LinearSolver;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// How the step size is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepSize {
    /// Error-controlled steps (methods with an error estimate); an exact flow takes one
    /// step per control interval (capped by `h_max`).
    Adaptive,
    /// Steps on the grid `t₀ + k·h` (plus every breakpoint and `t_end`), `h > 0`.
    Fixed(f64),
}

/// The smallest non-zero relative tolerance: 10 units of rounding (`10·ε ≈ 2.2e-15`).
pub const MIN_RTOL: f64 = 10.0 * f64::EPSILON;

/// Options shared by every method.
///
/// ```
/// use reckon::{Options, StepSize};
/// let o = Options::default().rtol(1e-8).atol(1e-10).h_max(0.5);
/// assert_eq!(o.step, StepSize::Adaptive);
/// assert!(o.validate().is_ok());
/// assert!(Options::default().step(StepSize::Fixed(0.0)).validate().is_err());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Relative tolerance (default 1e-6): 0, or at least [`MIN_RTOL`].
    pub rtol: Tolerance,
    /// Absolute tolerance (default 1e-9).
    pub atol: Tolerance,
    /// Step-size mode (default adaptive).
    pub step: StepSize,
    /// First step of an adaptive run; `None` selects it by Hairer's algorithm.
    pub h0: Option<f64>,
    /// Largest step magnitude (default ∞).
    pub h_max: f64,
    /// Limit on step attempts, accepted and rejected, between two consecutive stops
    /// (control breakpoints, [`breakpoints`](Options::breakpoints), `step_until`
    /// targets, `t_end`): default 100 000, as `dopri5.f` for a problem without
    /// breakpoints; with a control log the limit scales with its intervals.
    pub max_steps: usize,
    /// Extra times the integrator must land on exactly (besides control breakpoints).
    pub breakpoints: Vec<f64>,
    /// Keep each step's dense polynomial in the [`Solution`](crate::Solution) so that
    /// [`Solution::at`](crate::Solution::at) can interpolate anywhere in the span
    /// (default false: without it `at` returns [`Error::NoDenseOutput`]). Events and
    /// [`Save::At`] use the polynomials during the run and need no kept dense output.
    pub dense: bool,
    /// Run the stiffness test every this many accepted steps (default 1000, as `dopri5.f`);
    /// `None` switches it off.
    pub stiffness_check: Option<usize>,
    /// Consecutive failed implicit solves at one step before giving up (default 10).
    pub max_step_failures: usize,
    /// What [`Solution`](crate::Solution) keeps of the run (default: every step).
    pub save: Save,
    /// How the implicit methods solve with `I − c·J` (default [`LinearSolver::Auto`]).
    pub linear_solver: LinearSolver,
    /// `Some(m)`: only the first `m` components enter the error estimate (and the initial
    /// step's norms); the rest are integrated with the same steps but not controlled:
    /// auxiliary quantities such as sensitivities ([`crate::sensitivity`]) or quadratures.
    /// `None` (the default): every component.
    pub error_components: Option<usize>,
    /// When resetting events count as a Zeno execution ([`Error::Zeno`]).
    pub zeno: ZenoLimit,
}

/// Resetting events that accumulate end the run with [`Error::Zeno`]: `count`
/// occurrences (of any resetting events) within `window·|t_end − t0|` of time
/// (`window·max(1, |t − t0|)` on an open-ended span). Default: 10 within 10⁻⁹ of the
/// span. A step that cannot advance right after such a run of resets (the next one is
/// closer than `t` resolves) is the same error.
///
/// ```
/// use reckon::{Options, problem::options::ZenoLimit};
/// let o = Options::default().zeno(50, 1e-6);
/// assert_eq!(o.zeno, ZenoLimit { count: 50, window: 1e-6 });
/// assert!(o.validate().is_ok());
/// assert!(Options::default().zeno(0, 1e-6).validate().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZenoLimit {
    /// Occurrences (at least 2).
    pub count: usize,
    /// Relative width of the window (finite, non-negative).
    pub window: f64,
}

impl Default for ZenoLimit {
    fn default() -> Self {
        ZenoLimit {
            count: 10,
            window: 1e-9,
        }
    }
}

/// What a [`Solution`](crate::Solution) keeps: the states at `t0` and at every accepted
/// step (the default), at every k-th one, at the end only, or at given output times
/// (`t_eval` in scipy, `saveat` in DifferentialEquations.jl) evaluated from each step's
/// dense polynomial as the run passes them, without storing the polynomials.
/// [`Options::dense`] (off by default) is independent: it keeps the polynomials for
/// [`Solution::at`](crate::Solution::at); `At(times)` works without it.
///
/// ```
/// use reckon::{model, methods::Rk45, problem::options::Save, Options, Problem};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 2.0));
/// let o = Options::default().rtol(1e-10).atol(1e-12); // dense output off (the default)
/// let s = p.solve(Rk45, &o.clone().save(Save::At(vec![0.5, 1.0, 1.5]))).unwrap();
/// assert_eq!(s.t, [0.5, 1.0, 1.5]);
/// assert!((s.x[1][0] - (-1.0f64).exp()).abs() < 1e-9);
/// let e = p.solve(Rk45, &o.save(Save::End)).unwrap();
/// assert_eq!(e.t, [0.0, 2.0]); // the start and the end
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Save {
    /// `t0` and every accepted step (and every breakpoint landed on).
    #[default]
    Steps,
    /// `t0`, every k-th accepted step, and the end.
    Every(usize),
    /// `t0` and the end.
    End,
    /// Exactly these times, strictly in the direction of integration, inside the span; a
    /// run that stops early (a terminal event) keeps those it reached and then the state
    /// where it stopped.
    At(Vec<f64>),
}

impl Default for Options {
    fn default() -> Self {
        Options {
            rtol: Tolerance::Scalar(1e-6),
            atol: Tolerance::Scalar(1e-9),
            step: StepSize::Adaptive,
            h0: None,
            h_max: f64::INFINITY,
            max_steps: 100_000,
            breakpoints: Vec::new(),
            dense: false,
            stiffness_check: Some(1000),
            max_step_failures: 10,
            save: Save::Steps,
            linear_solver: LinearSolver::Auto,
            error_components: None,
            zeno: ZenoLimit::default(),
        }
    }
}

impl Options {
    /// Set the relative tolerance (scalar or per component).
    pub fn rtol(mut self, rtol: impl Into<Tolerance>) -> Self {
        self.rtol = rtol.into();
        self
    }
    /// Set the absolute tolerance (scalar or per component).
    pub fn atol(mut self, atol: impl Into<Tolerance>) -> Self {
        self.atol = atol.into();
        self
    }
    /// Set the step-size mode.
    pub fn step(mut self, step: StepSize) -> Self {
        self.step = step;
        self
    }
    /// Fixed steps of size `h` (shorthand for `step(StepSize::Fixed(h))`).
    pub fn fixed(self, h: f64) -> Self {
        self.step(StepSize::Fixed(h))
    }
    /// Set the first adaptive step.
    pub fn h0(mut self, h0: f64) -> Self {
        self.h0 = Some(h0);
        self
    }
    /// Set the largest step.
    pub fn h_max(mut self, h_max: f64) -> Self {
        self.h_max = h_max;
        self
    }
    /// Set the step limit.
    pub fn max_steps(mut self, n: usize) -> Self {
        self.max_steps = n;
        self
    }
    /// Add times to land on exactly.
    pub fn breakpoints(mut self, b: impl IntoIterator<Item = f64>) -> Self {
        self.breakpoints.extend(b);
        self
    }
    /// Keep (`true`) or drop (`false`, the default) each step's dense polynomial: with
    /// it, [`Solution::at`](crate::Solution::at) evaluates `x(t₀ + θh) = Σ_j c_j θʲ` anywhere in
    /// the span; without it, `at` between kept points is [`Error::NoDenseOutput`].
    ///
    /// ```
    /// use reckon::{model, methods::Rk45, Error, Options, Problem};
    /// use nalgebra::vector;
    /// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
    /// let p = Problem::new(&f, vector![1.0], (0.0, 2.0));
    /// assert!(!Options::default().dense);
    /// let lean = p.solve(Rk45, &Options::default()).unwrap();
    /// assert!(lean.dense_segments().is_empty());
    /// assert!(matches!(lean.at(0.7), Err(Error::NoDenseOutput { t }) if t == 0.7));
    /// let o = Options::default().rtol(1e-9).atol(1e-12).dense(true);
    /// let sol = p.solve(Rk45, &o).unwrap();
    /// assert!((sol.at(0.7).unwrap()[0] - (-0.7f64).exp()).abs() < 1e-8);
    /// ```
    pub fn dense(mut self, on: bool) -> Self {
        self.dense = on;
        self
    }

    /// Choose what the solution keeps ([`Save`]).
    pub fn save(mut self, save: Save) -> Self {
        self.save = save;
        self
    }
    /// Control the error of the first `m` components only ([`Options::error_components`]).
    ///
    /// ```
    /// use reckon::{model, Options, Problem, methods::Rk45};
    /// use nalgebra::vector;
    /// // x' = −x with a quadrature q' = x² riding along uncontrolled
    /// let f = model!(|_t, x: [S; 2]| vector![-x[0], x[0] * x[0]]);
    /// let p = Problem::new(&f, vector![1.0, 0.0], (0.0, 1.0));
    /// let both = p.solve(Rk45, &Options::default()).unwrap();
    /// let one = p.solve(Rk45, &Options::default().error_components(1)).unwrap();
    /// let g = model!(|_t, x: [S; 1]| vector![-x[0]]);
    /// let alone = Problem::new(&g, vector![1.0], (0.0, 1.0)).solve(Rk45, &Options::default()).unwrap();
    /// assert_eq!(one.t, alone.t); // the same steps as x alone
    /// assert!(both.t.len() >= one.t.len());
    /// assert!((one.last().1[1] - (1.0 - (-2.0f64).exp()) / 2.0).abs() < 1e-5);
    /// ```
    pub fn error_components(mut self, m: usize) -> Self {
        self.error_components = Some(m);
        self
    }
    /// Set when resetting events count as Zeno ([`ZenoLimit`]).
    pub fn zeno(mut self, count: usize, window: f64) -> Self {
        self.zeno = ZenoLimit { count, window };
        self
    }
    /// Choose the implicit methods' linear algebra ([`LinearSolver`]).
    pub fn linear_solver(mut self, l: LinearSolver) -> Self {
        self.linear_solver = l;
        self
    }
    /// Stiffness test interval (`None`: off).
    pub fn stiffness_check(mut self, every: Option<usize>) -> Self {
        self.stiffness_check = every;
        self
    }

    /// Check every field; the integrator calls this before it starts.
    pub fn validate(&self) -> Result<()> {
        // the first value of a tolerance failing `bad` (a scalar is checked without a loop)
        let first = |tol: &Tolerance, bad: fn(f64) -> bool| match tol {
            Tolerance::Scalar(v) => bad(*v).then_some(*v),
            Tolerance::PerComponent(v) => v.iter().copied().find(|v| bad(*v)),
        };
        for (what, tol) in [("rtol", &self.rtol), ("atol", &self.atol)] {
            if let Some(v) = first(tol, |v| !(v.is_finite() && v >= 0.0)) {
                return Err(Error::invalid(
                    what,
                    format!("must be finite and non-negative, got {}", crate::error::Brief(v)),
                ));
            }
        }
        // a relative tolerance below the rounding unit cannot be met: every adaptive
        // method would shrink its step to the step limit (scipy raises it to 100·ε)
        if let Some(v) = first(&self.rtol, |v| v > 0.0 && v < MIN_RTOL) {
            return Err(Error::invalid(
                "rtol",
                format!(
                    "{} is below what double precision can meet: use 0 (absolute control only) or at least {MIN_RTOL:e}",
                    crate::error::Brief(v)
                ),
            ));
        }
        let positive = |what: &'static str, v: f64| {
            if v > 0.0 && !v.is_nan() {
                Ok(())
            } else {
                Err(Error::invalid(
                    what,
                    format!("must be positive, got {}", crate::error::Brief(v)),
                ))
            }
        };
        if let StepSize::Fixed(h) = self.step {
            positive("step", h)?;
            if !h.is_finite() {
                return Err(Error::invalid("step", "a fixed step must be finite"));
            }
        }
        if let Some(h0) = self.h0 {
            positive("h0", h0)?;
        }
        positive("h_max", self.h_max)?;
        if self.max_steps == 0 {
            return Err(Error::invalid("max_steps", "must be at least 1"));
        }
        if self.stiffness_check == Some(0) {
            return Err(Error::invalid("stiffness_check", "interval must be at least 1"));
        }
        match &self.save {
            Save::Every(0) => return Err(Error::invalid("save", "Every(k) needs k ≥ 1")),
            Save::At(ts) if ts.is_empty() => {
                return Err(Error::invalid("save", "At(times) needs at least one time"));
            }
            Save::At(ts) => {
                if let Some(t) = ts.iter().find(|t| !t.is_finite()) {
                    return Err(Error::invalid(
                        "save",
                        format!("output times must be finite, got {}", crate::error::Brief(*t)),
                    ));
                }
            }
            _ => {}
        }
        if self.zeno.count < 2 || !(self.zeno.window.is_finite() && self.zeno.window >= 0.0) {
            return Err(Error::invalid(
                "zeno",
                format!(
                    "needs a count of at least 2 and a finite non-negative window, got ({}, {})",
                    self.zeno.count,
                    crate::error::Brief(self.zeno.window)
                ),
            ));
        }
        if let Some(b) = self.breakpoints.iter().find(|b| !b.is_finite()) {
            return Err(Error::invalid(
                "breakpoints",
                format!("must be finite, got {}", crate::error::Brief(*b)),
            ));
        }
        Ok(())
    }
}

/// A tolerance, one value for every component or one per component.
#[derive(Debug, Clone, PartialEq)]
pub enum Tolerance {
    /// The same value for every component.
    Scalar(f64),
    /// One value per component (length must equal the state dimension).
    PerComponent(Vec<f64>),
}

impl From<f64> for Tolerance {
    fn from(v: f64) -> Self {
        Tolerance::Scalar(v)
    }
}

impl From<Vec<f64>> for Tolerance {
    fn from(v: Vec<f64>) -> Self {
        Tolerance::PerComponent(v)
    }
}

impl Tolerance {
    /// Expand to one value per component, checking sign and length.
    pub(crate) fn expand<D: Dim>(&self, what: &'static str, dim: D) -> Result<OVector<f64, D>>
    where
        DefaultAllocator: Allocator<D>,
    {
        let n = dim.value();
        // the given values (one for a scalar) are checked, not the n copies of them
        let given: &[f64] = match self {
            Tolerance::Scalar(a) => std::slice::from_ref(a),
            Tolerance::PerComponent(v) => {
                if v.len() != n {
                    return Err(Error::invalid(
                        what,
                        format!("{} values given for a state of {} components", v.len(), n),
                    ));
                }
                v
            }
        };
        if let Some(bad) = given.iter().find(|a| !(a.is_finite() && **a >= 0.0)) {
            return Err(Error::invalid(
                what,
                format!("must be finite and non-negative, got {}", crate::error::Brief(*bad)),
            ));
        }
        let v = match self {
            Tolerance::Scalar(a) => OVector::<f64, D>::from_element_generic(dim, nalgebra::U1, *a),
            Tolerance::PerComponent(v) => {
                OVector::<f64, D>::from_iterator_generic(dim, nalgebra::U1, v.iter().copied())
            }
        };
        Ok(v)
    }
}

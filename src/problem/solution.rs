//! The result of an integration: times, states, dense output, statistics, events.

use crate::error::{Error, Result};
use crate::model::Stats;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Where the problem was found stiff (DOPRI5's test: `h·λ > 3.25` on 15 checks
/// not separated by 6 non-stiff ones).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stiffness {
    /// Time of the verdict.
    pub t: f64,
    /// `|h·λ|` estimate at that time.
    pub h_lambda: f64,
}

/// A switch of an auto-switching method ([`Auto`](crate::methods::Auto)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Switch {
    /// Time of the switch (the end of the last step of the old method).
    pub t: f64,
    /// The method switched to.
    pub to: &'static str,
    /// Why, with the estimate that decided it (on the last of the steps that did).
    pub reason: SwitchReason,
}

/// Why [`Auto`](crate::methods::Auto) switched.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SwitchReason {
    /// DOPRI5's step was set by the edge of its stability region: Hairer's `|h·λ|`
    /// above [`STIFF_H_LAMBDA`](crate::methods::auto::STIFF_H_LAMBDA).
    Stiff {
        /// `|h·λ|` of the last step.
        h_lambda: f64,
    },
    /// The other method's estimated cost per unit time (`f` evaluations per unit `t`,
    /// see [`Auto`](crate::methods::Auto)) was lower by
    /// [`COST_MARGIN`](crate::methods::auto::COST_MARGIN).
    Cost {
        /// The method in use.
        from: f64,
        /// The method switched to.
        to: f64,
    },
}

impl std::fmt::Display for SwitchReason {
    /// ```
    /// use reckon::SwitchReason;
    /// assert_eq!(SwitchReason::Stiff { h_lambda: 2.5 }.to_string(), "stiff: |h·λ| = 2.5");
    /// assert_eq!(
    ///     SwitchReason::Cost { from: 1200.0, to: 150.0 }.to_string(),
    ///     "cheaper: 150 against 1200 f evaluations per unit time"
    /// );
    /// ```
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use crate::error::Brief;
        match self {
            SwitchReason::Stiff { h_lambda } => write!(f, "stiff: |h·λ| = {}", Brief(*h_lambda)),
            SwitchReason::Cost { from, to } => write!(
                f,
                "cheaper: {} against {} f evaluations per unit time",
                Brief(*to),
                Brief(*from)
            ),
        }
    }
}

/// A zero of an event function `g(t, x)` found during the integration.
#[derive(Debug, Clone, PartialEq)]
pub struct EventHit<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Index of the event in the order given.
    pub index: usize,
    /// Time of the zero.
    pub t: f64,
    /// State at that time (from dense output); before the reset for a resetting event.
    pub x: OVector<f64, D>,
    /// The state the event's reset map put in its place (`None` for an event without
    /// a reset, and at the occurrence that stopped the run).
    pub x_after: Option<OVector<f64, D>>,
}

/// One step's dense polynomial `x(t₀ + θh) = Σ_j c_j θʲ`, `θ ∈ [0, 1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct DenseSegment<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Step start.
    pub t0: f64,
    /// Step size (negative backward).
    pub h: f64,
    /// End of the segment (`t0 + h`, or an earlier terminal event).
    pub t1: f64,
    /// Coefficients in powers of θ.
    pub c: Vec<OVector<f64, D>>,
}

impl<D: Dim> DenseSegment<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// Evaluate at `t` by Horner's rule in θ = (t − t₀)/h.
    pub fn eval(&self, t: f64) -> OVector<f64, D> {
        let theta = (t - self.t0) / self.h;
        horner(&self.c, theta)
    }
}

/// `Σ_j c_j θʲ` by Horner's rule.
pub(crate) fn horner<D: Dim>(c: &[OVector<f64, D>], theta: f64) -> OVector<f64, D>
where
    DefaultAllocator: Allocator<D>,
{
    let mut y = c[c.len() - 1].clone();
    for cj in c[..c.len() - 1].iter().rev() {
        y *= theta;
        y += cj;
    }
    y
}

/// Times and states at every step end (and every breakpoint), with statistics.
#[derive(Debug, Clone)]
pub struct Solution<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Times, starting at `t0`, ending at `t_end` (or a terminal event). A reset
    /// appears twice: the state before it, then the state after it, at the same time.
    pub t: Vec<f64>,
    /// States at those times.
    pub x: Vec<OVector<f64, D>>,
    /// Counters.
    pub stats: Stats,
    /// Event zeros in time order (simultaneous ones in the order the events were given).
    pub events: Vec<EventHit<D>>,
    /// Set when the stiffness test fired (the run still completes).
    pub stiffness: Option<Stiffness>,
    /// Name of the method that produced this solution.
    pub method: &'static str,
    /// Every method switch of an auto-switching method, in time order (empty otherwise).
    pub switches: Vec<Switch>,
    pub(crate) dense: Vec<DenseSegment<D>>,
    /// The initial state the run started from when it differs from the problem's: a
    /// DAE's algebraic components put on their equations (`Some` only then).
    pub x0_corrected: Option<OVector<f64, D>>,
}

impl<D: Dim> Solution<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// The final time and state.
    pub fn last(&self) -> (f64, &OVector<f64, D>) {
        let n = self.t.len() - 1;
        (self.t[n], &self.x[n])
    }

    /// Bytes of data kept: `8` per time, `8·n` per state, and per dense segment `24` (its
    /// three times) plus `8·n` per coefficient vector (heap and inline alike; `Vec`
    /// headers and spare capacity are not counted).
    ///
    /// ```
    /// use reckon::{model, methods::Rk45, Options, Problem, Save};
    /// use nalgebra::vector;
    /// let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    /// let p = Problem::new(&f, vector![1.0, 0.0], (0.0, 100.0));
    /// let s = p.solve(Rk45, &Options::default().dense(false).save(Save::End)).unwrap();
    /// assert_eq!(s.kept_bytes(), 2 * 8 + 2 * 16); // two times, two 2-vectors
    /// ```
    pub fn kept_bytes(&self) -> usize {
        let n = self.x.first().map_or(0, |x| x.len());
        let seg = |s: &DenseSegment<D>| 24 + s.c.len() * 8 * n;
        self.t.len() * 8 + self.x.len() * 8 * n + self.dense.iter().map(seg).sum::<usize>()
    }

    /// The dense segments (one per accepted step, each `x(t₀ + θh) = Σ_j c_j θʲ`), empty
    /// unless [`Options::dense(true)`](crate::Options::dense) was set.
    ///
    /// ```
    /// use reckon::{model, methods::Rk45, Options, Problem};
    /// use nalgebra::vector;
    /// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
    /// let p = Problem::new(&f, vector![1.0], (0.0, 2.0));
    /// assert!(p.solve(Rk45, &Options::default()).unwrap().dense_segments().is_empty());
    /// let s = p.solve(Rk45, &Options::default().dense(true)).unwrap();
    /// assert_eq!(s.dense_segments().len(), s.t.len() - 1);
    /// ```
    pub fn dense_segments(&self) -> &[DenseSegment<D>] {
        &self.dense
    }

    /// The state at any `t` inside the span, `x(t₀ + θh) = Σ_j c_j θʲ` on the step that
    /// holds `t`, from the method's dense output (4th order for RK45, linear for the
    /// Euler methods, quartic through the midpoint for exact flows and
    /// exponential Euler). The polynomials are kept only with
    /// [`Options::dense(true)`](crate::Options::dense); a run without them (the default)
    /// returns [`Error::NoDenseOutput`], which names that fix.
    ///
    /// ```
    /// use reckon::{model, Error, Options, Problem, methods::Rk45};
    /// use nalgebra::vector;
    /// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
    /// let p = Problem::new(&f, vector![1.0], (0.0, 2.0));
    /// let sol = p.solve(Rk45, &Options::default().rtol(1e-9).atol(1e-12).dense(true)).unwrap();
    /// assert!((sol.at(0.7).unwrap()[0] - (-0.7f64).exp()).abs() < 1e-8); // between steps
    /// assert!(sol.at(2.5).is_err()); // outside the span
    /// let lean = p.solve(Rk45, &Options::default()).unwrap(); // dense off
    /// let e = lean.at(0.7).unwrap_err();
    /// assert_eq!(e, Error::NoDenseOutput { t: 0.7 });
    /// assert!(e.to_string().contains("Options::dense(true)"));
    /// ```
    pub fn at(&self, t: f64) -> Result<OVector<f64, D>> {
        if self.dense.is_empty() {
            return if self.t.len() == 1 && t == self.t[0] {
                Ok(self.x[0].clone())
            } else {
                Err(Error::NoDenseOutput { t })
            };
        }
        // the segments' span: with `Save::At` the saved times need not reach its ends
        let (a, b) = (self.dense[0].t0, self.dense[self.dense.len() - 1].t1);
        let (lo, hi) = (a.min(b), a.max(b));
        if !(t >= lo && t <= hi) {
            return Err(Error::invalid(
                "t",
                format!("{t} is outside the solved span [{lo}, {hi}]"),
            ));
        }
        let forward = self.dense[0].h > 0.0;
        // first segment whose end is at or past t in the direction of integration
        let k = self
            .dense
            .partition_point(|s| if forward { s.t1 < t } else { s.t1 > t });
        Ok(self.dense[k.min(self.dense.len() - 1)].eval(t))
    }
}

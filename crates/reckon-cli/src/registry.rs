//! The problems the study commands know, behind one object-safe interface.

use nalgebra::allocator::Allocator;
use nalgebra::{Const, DefaultAllocator, Dim, OVector, SVector, vector};
use reckon::linalg::LuDim;
use reckon::linalg::arnoldi::{SPARSE_MIN_STATES, SpectralOptions};
use reckon::methods::{Auto, Bdf, ImplicitEuler, Method, Rk45, Rodas5P};
use reckon::model::Flow;
use reckon::studies::MethodKind;
use reckon::studies::convergence::{Convergence, check, convergence};
use reckon::studies::problems::*;
use reckon::studies::stiffness::{StiffnessPoint, sampled_stiffness, stiffness_along};
use reckon::studies::work_precision::{WorkPoint, work_precision_scaled};
use reckon::vehicles::{bicycle, carlike, unicycle};
use reckon::{Controls, Error, Options, Problem, Result, Solution, System};

/// A step-size history, possibly cut short by an error (RK45 on a stiff problem).
#[derive(Debug, Clone, serde::Serialize)]
pub struct History {
    pub method: &'static str,
    pub t: Vec<f64>,
    pub h: Vec<f64>,
    pub accepted: u64,
    pub rejected: u64,
    pub rhs_evals: u64,
    pub stiff_at: Option<f64>,
    pub reached: f64,
    pub stopped_by: Option<String>,
}

/// The stiffness points of a run and how they were computed.
#[derive(Debug, Clone)]
pub struct StiffnessRun {
    pub points: Vec<StiffnessPoint>,
    /// Every how many accepted steps a point was taken (1: every step).
    pub every: usize,
    /// `true`: the sparse estimate (Arnoldi, sparse LU), `false`: dense QR eigenvalues.
    pub sparse: bool,
}

/// `brusselator:N` below this many states has an RK45 reference at 1e-12 (its stable step
/// ≈ 3.3/(0.08·N²) is then ≥ 1.6·10⁻⁴: under 10⁵ steps on [0, 10]), from it Rodas5P's at 1e-10.
pub const RK_REFERENCE_MAX_STATES: usize = 1_000;

/// At most this many stiffness points on the sparse path (`SPARSE_MIN_STATES` states or
/// more): every `k`-th step of the implicit-Euler run, `k = ⌈steps/50⌉`.
pub const SPARSE_SAMPLES: usize = 50;

/// RK45's step cap in `stiffness` on a problem of `SPARSE_MIN_STATES` states or more:
/// its stable step there is tiny (BRUSS with N grid points: ≈ 3.3/(0.08·N²), 4·10⁻⁹ s at
/// N = 10⁵), so its history is the first 1 000 steps, which show the stability limit,
/// instead of hours of them.
pub const LARGE_RK45_STEPS: usize = 1_000;

pub trait StudyProblem {
    fn name(&self) -> &str;
    fn describe(&self) -> &str;
    /// Default fixed steps for `method`: first-order methods and exact flows use the
    /// problem's list, RK45 a coarser one so that its errors stay above round-off.
    fn default_steps(&self, method: MethodKind) -> Vec<f64>;
    /// Refuse a convergence study before any run (no path reference, fewer than two
    /// steps, a step that needs more than `max_steps` steps).
    fn check_convergence(&self, methods: &[MethodKind], steps: &[f64], max_steps: u64) -> Result<()>;
    fn convergence(&self, methods: &[MethodKind], steps: &[f64], max_steps: u64) -> Result<Convergence>;
    fn histories(&self, rtol: f64, atol: f64, max_steps: usize) -> Vec<History>;
    /// The Jacobian's eigenvalues and the stiffness index at every step of an
    /// implicit-Euler run (A-stable: its steps are set by accuracy alone); from
    /// `SPARSE_MIN_STATES` states on, for a model with a sparse Jacobian, the sparse
    /// estimate at at most `SPARSE_SAMPLES` of its steps.
    /// `steps`: the accepted steps of an implicit-Euler run at these tolerances if known
    /// (its history), which spares the sparse path a counting run.
    fn stiffness_points(&self, rtol: f64, atol: f64, steps: Option<usize>) -> Result<StiffnessRun>;
    fn work_precision(
        &self,
        methods: &[MethodKind],
        tols: &[f64],
        steps: &[f64],
        runs: usize,
    ) -> Result<Vec<WorkPoint>>;
}

type ExactFn<D> = Box<dyn Fn(f64) -> OVector<f64, D>>;

struct Spec<D: Dim, S>
where
    DefaultAllocator: Allocator<D>,
{
    name: String,
    describe: String,
    problem: Problem<'static, D, S>,
    exact: Option<ExactFn<D>>,
    reference_end: Option<OVector<f64, D>>,
    flow: Option<Box<dyn Flow<D>>>,
    steps: Vec<f64>,
    rk45_steps: Vec<f64>,
    /// true when a path reference may be computed with RK45 at 1e-12 (non-stiff)
    rk_reference: bool,
    /// atol = this · rtol in work–precision runs (the Test Set's convention per problem)
    atol_over_rtol: f64,
}

fn history<D: Dim, S: System<D>, M: Method<D>>(p: &Problem<'_, D, S>, m: M, opts: &Options) -> History
where
    DefaultAllocator: Allocator<D>,
{
    let h = reckon::studies::stiffness::history(p, m, opts);
    History {
        method: h.method,
        t: h.t,
        h: h.h,
        accepted: h.stats.accepted,
        rejected: h.stats.rejected,
        rhs_evals: h.stats.rhs_evals,
        stiff_at: h.stiffness.map(|s| s.t),
        reached: h.reached,
        stopped_by: h.stopped_by.map(|e| e.to_string()),
    }
}

impl<D: LuDim, S: System<D>> Spec<D, S>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn flow(&self) -> Option<&dyn Flow<D>> {
        self.flow.as_deref()
    }
    /// RK45 at 1e-12 on a non-stiff problem, Rodas5P at 1e-10 on a stiff one (too large or
    /// too stiff for RK45).
    fn reference_solution(&self) -> Result<Solution<D>> {
        if !self.rk_reference {
            return self
                .problem
                .solve(Rodas5P, &Options::default().rtol(1e-10).atol(1e-10).dense(false));
        }
        self.problem.solve(
            Rk45,
            &Options::default()
                .rtol(1e-12)
                .atol(1e-12)
                .dense(true)
                .max_steps(2_000_000),
        )
    }
    fn states(&self) -> usize {
        self.problem.x0.len()
    }
    fn u0(&self) -> Vec<f64> {
        self.problem
            .controls
            .as_ref()
            .and_then(|c| c.values(0).map(|v| v.to_vec()))
            .unwrap_or_default()
    }
}

impl<D: LuDim, S: System<D>> StudyProblem for Spec<D, S>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn name(&self) -> &str {
        &self.name
    }
    fn describe(&self) -> &str {
        &self.describe
    }
    fn default_steps(&self, method: MethodKind) -> Vec<f64> {
        match method {
            MethodKind::Rk45 => self.rk45_steps.clone(),
            _ => self.steps.clone(),
        }
    }
    fn check_convergence(&self, methods: &[MethodKind], steps: &[f64], max_steps: u64) -> Result<()> {
        if self.exact.is_none() && !self.rk_reference {
            return Err(Error::invalid(
                "problem",
                format!(
                    "'{}' is stiff and has a reference only at its end time: study it with `reckon stiffness` or `reckon work-precision`",
                    self.name
                ),
            ));
        }
        check(&self.problem, methods, steps, self.flow.is_some(), max_steps)
    }
    fn convergence(&self, methods: &[MethodKind], steps: &[f64], max_steps: u64) -> Result<Convergence> {
        self.check_convergence(methods, steps, max_steps)?;
        if let Some(exact) = &self.exact {
            return convergence(&self.problem, methods, steps, exact.as_ref(), self.flow(), max_steps);
        }
        let r = self.reference_solution()?;
        let exact = move |t: f64| r.at(t).unwrap_or_else(|_| r.last().1.clone());
        convergence(&self.problem, methods, steps, &exact, self.flow(), max_steps)
    }
    fn histories(&self, rtol: f64, atol: f64, max_steps: usize) -> Vec<History> {
        let opts = Options::default()
            .rtol(rtol)
            .atol(atol)
            .dense(false)
            .max_steps(max_steps);
        let rk45 = if self.states() >= SPARSE_MIN_STATES {
            opts.clone().max_steps(max_steps.min(LARGE_RK45_STEPS))
        } else {
            opts.clone()
        };
        vec![
            history(&self.problem, Rk45, &rk45),
            // per-step control, as RK45's: the two step counts then compare the step
            // that accuracy allows with the step that stability allows
            history(&self.problem, ImplicitEuler::default().proportional(false), &opts),
            history(&self.problem, Bdf::default(), &opts),
            history(&self.problem, Rodas5P, &opts),
            history(&self.problem, Auto::default(), &opts),
        ]
    }
    fn stiffness_points(&self, rtol: f64, atol: f64, steps: Option<usize>) -> Result<StiffnessRun> {
        let opts = Options::default().rtol(rtol).atol(atol).dense(false);
        let n = self.states();
        if n >= SPARSE_MIN_STATES && self.problem.system.sparse_jacobian(n).is_some() {
            let (points, every) = sampled_stiffness(
                &self.problem,
                || ImplicitEuler::default().proportional(false),
                &opts,
                SPARSE_SAMPLES,
                steps,
                &self.u0(),
                &SpectralOptions::default(),
            )?;
            return Ok(StiffnessRun {
                points,
                every,
                sparse: true,
            });
        }
        let sol = self
            .problem
            .solve(ImplicitEuler::default().proportional(false), &opts)?;
        Ok(StiffnessRun {
            points: stiffness_along(&self.problem.system, &sol, &self.u0(), 1)?,
            every: 1,
            sparse: false,
        })
    }
    fn work_precision(
        &self,
        methods: &[MethodKind],
        tols: &[f64],
        steps: &[f64],
        runs: usize,
    ) -> Result<Vec<WorkPoint>> {
        let reference = match (&self.exact, &self.reference_end) {
            (Some(e), _) => e(self.problem.t_end),
            (None, Some(r)) => r.clone(),
            (None, None) => self.reference_solution()?.last().1.clone(),
        };
        work_precision_scaled(
            &self.problem,
            methods,
            tols,
            steps,
            &reference,
            self.flow(),
            runs,
            self.atol_over_rtol,
        )
    }
}

fn spec<D: LuDim, S: System<D> + 'static>(
    name: &'static str,
    describe: &'static str,
    problem: Problem<'static, D, S>,
    exact: Option<ExactFn<D>>,
    (steps, rk45_steps): (Vec<f64>, Vec<f64>),
) -> Spec<D, S>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    Spec {
        name: name.to_string(),
        describe: describe.to_string(),
        problem,
        exact,
        reference_end: None,
        flow: None,
        steps,
        rk45_steps,
        rk_reference: true,
        atol_over_rtol: 1.0,
    }
}

fn halvings(h0: f64, n: usize) -> Vec<f64> {
    (0..n).map(|k| h0 / 2f64.powi(k as i32)).collect()
}

pub const NAMES: [&str; 15] = [
    "rotation-decay",
    "lti",
    "dahlquist",
    "sin-u",
    "stiff-cosine",
    "arenstorf",
    "lorenz",
    "unicycle",
    "bicycle",
    "carlike",
    "van-der-pol",
    "robertson",
    "brusselator",
    "orego",
    "hires",
];

fn vehicle_controls() -> Controls {
    Controls::new(
        vec![0.0, 1.0, 2.0, 3.0, 4.0],
        vec![
            vec![1.0, 0.8],
            vec![2.0, -0.5],
            vec![1.5, 0.0],
            vec![0.5, 0.3],
            vec![0.0, 0.0],
        ],
    )
    .expect("valid controls")
}

/// Exact solution of a model with held inputs at any t: integrate its flow to t.
fn flow_exact<const N: usize, S: System<Const<N>> + Clone + 'static, F: Flow<Const<N>> + Clone + 'static>(
    sys: S,
    flow: F,
    x0: SVector<f64, N>,
    c: Controls,
) -> ExactFn<Const<N>> {
    Box::new(move |t: f64| {
        if t == 0.0 {
            return x0;
        }
        let p = Problem::new(sys.clone(), x0, (0.0, t)).controls(c.clone());
        p.solve(
            reckon::methods::Exact::new(flow.clone()),
            &Options::default().dense(false),
        )
        .map(|s| *s.last().1)
        .unwrap_or(SVector::repeat(f64::NAN))
    })
}

/// The largest `brusselator:N`: 5·10⁵ grid points, 10⁶ states, the largest size measured
/// (tracing its body peaks at 1.69 GiB; memory grows linearly, so 5·10⁶ points would need
/// about 17 GiB).
pub const BRUSSELATOR_MAX_N: usize = 500_000;

/// `"brusselator:N" ↦ N ∈ [1, 5·10⁵]`: the grid size of a `brusselator:N` problem name,
/// `None` without the prefix, `Some(Err(message))` unless `N` is a whole number from 1 to
/// [`BRUSSELATOR_MAX_N`] (shared by `reckon jacobian` and the study commands).
///
/// ```
/// use reckon_cli::registry::brusselator_size;
/// assert_eq!(brusselator_size("brusselator:100000"), Some(Ok(100_000)));
/// assert_eq!(brusselator_size("robertson"), None);
/// for bad in ["brusselator:0", "brusselator:abc", "brusselator:500001", "brusselator:5000000"] {
///     assert!(brusselator_size(bad).unwrap().unwrap_err().contains("from 1 to 500000"));
/// }
/// ```
pub fn brusselator_size(name: &str) -> Option<std::result::Result<usize, String>> {
    let n = name.strip_prefix("brusselator:")?;
    Some(
        n.parse()
            .ok()
            .filter(|&n| (1..=BRUSSELATOR_MAX_N).contains(&n))
            .ok_or_else(|| {
                format!(
                    "brusselator:N needs N from 1 to {BRUSSELATOR_MAX_N} grid points (10⁶ states; tracing that takes 1.7 GiB, and memory grows with N), got '{n}'"
                )
            }),
    )
}

/// BRUSS 1-D with `n` grid points (`2n` states) on `[0, 10]`: the traced model, whose
/// compiled sparse Jacobian the implicit methods use from 64 states (`LinearSolver::Auto`)
/// and the stiffness study from `SPARSE_MIN_STATES`.
fn brusselator_n(n: usize) -> Box<dyn StudyProblem> {
    let large = 2 * n >= SPARSE_MIN_STATES;
    let rk_reference = 2 * n < RK_REFERENCE_MAX_STATES;
    let describe = format!(
        "1-D Brusselator, {n} grid points ({} unknowns, DVector, sparse LU from 64 unknowns), t in [0, 10]; {}",
        2 * n,
        match (rk_reference, large) {
            (true, false) => "reference RK45 at 1e-12",
            (true, true) =>
                "reference RK45 at 1e-12; stiffness estimated sparse (Arnoldi, sparse LU) at <= 50 steps, RK45 capped at 1000 steps",
            _ =>
                "reference Rodas5P at 1e-10; stiffness estimated sparse (Arnoldi, sparse LU) at <= 50 steps, RK45 capped at 1000 steps",
        }
    );
    let mut s = spec(
        "brusselator",
        "",
        Problem::new(brusselator(n), brusselator_y0(n), (0.0, 10.0)),
        None::<ExactFn<nalgebra::Dyn>>,
        (halvings(0.004, 5), halvings(0.05, 4)),
    );
    s.name = format!("brusselator:{n}");
    s.describe = describe;
    s.rk_reference = rk_reference;
    Box::new(s)
}

/// Look a problem up by name.
pub fn lookup(name: &str) -> std::result::Result<Box<dyn StudyProblem>, String> {
    let unknown = || format!("unknown problem '{name}' (known: {}, brusselator:N)", NAMES.join(", "));
    if let Some(n) = brusselator_size(name) {
        return Ok(brusselator_n(n?));
    }
    Ok(match name {
        "rotation-decay" => {
            let x0 = vector![1.0, 0.5];
            Box::new(spec(
                "rotation-decay",
                "x' = [[-0.5, -2], [2, -0.5]] x, x0 = (1, 0.5), t in [0, 5]; exact: matrix exponential",
                Problem::new(rotation_decay(), x0, (0.0, 5.0)),
                Some(Box::new(move |t| rotation_decay_exact(t, &x0))),
                (halvings(1.0 / 128.0, 5), halvings(0.2, 4)),
            ))
        }
        "lti" => {
            // damped spring driven by a held force: x'' = −4x − 0.4x' + u
            let lti = reckon::Lti::new(
                nalgebra::Matrix2::new(0.0, 1.0, -4.0, -0.4),
                nalgebra::Vector2::new(0.0, 1.0),
            )
            .expect("finite matrices of matching sizes");
            let c = Controls::new(
                vec![0.0, 1.0, 2.0, 3.0],
                vec![vec![1.0], vec![-0.5], vec![2.0], vec![0.0]],
            )
            .expect("increasing times");
            let x0 = vector![0.5, 0.0];
            let mut s = spec(
                "lti",
                "damped spring x'' = -4x - 0.4x' + u, u held over four 1-s intervals, x0 = (0.5, 0); exact: the zero-order-hold flow",
                Problem::new(lti.clone(), x0, (0.0, 4.0)).controls(c.clone()),
                Some(flow_exact(lti.clone(), lti.clone(), x0, c)),
                (halvings(1.0 / 128.0, 5), halvings(0.2, 4)),
            );
            s.flow = Some(Box::new(lti));
            Box::new(s)
        }
        "dahlquist" => {
            let f = reckon::model!(|_t, x: [S; 1]| vector![x[0] * -2.0]);
            Box::new(spec(
                "dahlquist",
                "x' = -2x, x0 = 1, t in [0, 5]; exact: e^(-2t)",
                Problem::new(f, vector![1.0], (0.0, 5.0)),
                Some(Box::new(|t: f64| vector![(-2.0 * t).exp()])),
                (halvings(1.0 / 256.0, 5), halvings(0.1, 4)),
            ))
        }
        "sin-u" => Box::new(spec(
            "sin-u",
            "u' = sin u, u0 = 0.5, t in [0, 5]; exact: 2 atan(e^t tan(u0/2))",
            Problem::new(sin_u(), vector![0.5], (0.0, 5.0)),
            Some(Box::new(|t| sin_u_exact(t, 0.5))),
            (halvings(1.0 / 16.0, 5), halvings(0.5, 4)),
        )),
        "stiff-cosine" => Box::new(spec(
            "stiff-cosine",
            "x' = -1000(x - cos t) - sin t, x0 = 1, t in [0, 2]; exact: cos t",
            Problem::new(stiff_cosine(), vector![1.0], (0.0, 2.0)),
            Some(Box::new(|t: f64| vector![t.cos()])),
            (halvings(1.0 / 2048.0, 5), halvings(0.0005, 4)),
        )),
        "arenstorf" => {
            let mut s = spec(
                "arenstorf",
                "Arenstorf orbit, one period (returns to y0); path reference RK45 at 1e-12",
                Problem::new(arenstorf(), arenstorf_y0(), (0.0, ARENSTORF_T)),
                None,
                (
                    halvings(ARENSTORF_T / 200_000.0, 4),
                    halvings(ARENSTORF_T / 20_000.0, 4),
                ),
            );
            s.reference_end = Some(arenstorf_y0());
            Box::new(s)
        }
        "lorenz" => Box::new(spec(
            "lorenz",
            "Lorenz (σ 10, ρ 28, β 8/3), y0 = (1, 1, 1), t in [0, 2]; reference RK45 at 1e-12",
            Problem::new(lorenz(), lorenz_y0(), (0.0, 2.0)),
            None,
            (halvings(0.0005, 5), halvings(0.01, 4)),
        )),
        "unicycle" => {
            let c = vehicle_controls();
            let x0 = vector![0.0, 0.0, 0.3];
            let mut s = spec(
                "unicycle",
                "unicycle with (v, ω) held over four 1-s intervals; exact: the arc",
                Problem::new(unicycle::model(), x0, (0.0, 4.0)).controls(c.clone()),
                Some(flow_exact(unicycle::model(), unicycle::flow, x0, c)),
                (halvings(0.1, 5), halvings(0.3, 4)),
            );
            s.flow = Some(Box::new(unicycle::flow));
            Box::new(s)
        }
        "bicycle" => {
            let c = Controls::new(
                vec![0.0, 1.0, 2.0, 3.0, 4.0],
                vec![
                    vec![2.0, 0.3],
                    vec![2.0, 0.0],
                    vec![2.0, -0.4],
                    vec![1.0, 0.2],
                    vec![0.0, 0.0],
                ],
            )
            .expect("valid controls");
            let x0 = vector![0.0, 0.0, 0.0];
            let mut s = spec(
                "bicycle",
                "kinematic bicycle, L = 0.5, v = 2, steering held over 1-s intervals; exact: the arc",
                Problem::new(bicycle::model(0.5), x0, (0.0, 4.0)).controls(c.clone()),
                Some(flow_exact(bicycle::model(0.5), bicycle::flow(0.5), x0, c)),
                (halvings(0.1, 5), halvings(0.3, 4)),
            );
            s.flow = Some(Box::new(bicycle::flow(0.5)));
            Box::new(s)
        }
        "carlike" => {
            let x0 = vector![0.0, 0.0, 0.0, 0.05];
            let c = Controls::new(
                vec![0.0, 1.0, 2.0],
                vec![vec![5.0, 0.3], vec![4.0, -0.5], vec![0.0, 0.0]],
            )
            .expect("valid controls");
            let mut s = spec(
                "carlike",
                "car-like, L = 2.5, (v, steering rate) held; exact: closed-form steering and heading, positions by adaptive Gauss-Kronrod quadrature (to ~1e-14)",
                Problem::new(carlike::model(2.5), x0, (0.0, 2.0)).controls(c.clone()),
                Some(flow_exact(carlike::model(2.5), carlike::flow(2.5), x0, c)),
                (halvings(0.05, 5), halvings(0.25, 4)),
            );
            s.flow = Some(Box::new(carlike::flow(2.5)));
            Box::new(s)
        }
        "van-der-pol" => {
            let mut s = spec(
                "van-der-pol",
                "Van der Pol μ = 1000, y0 = (2, 0), t in [0, 2000]; reference y(2000) from the Test Set (VDPOLM)",
                Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 2000.0)),
                None,
                (vec![], vec![]),
            );
            s.reference_end = Some(vector![1.706167732170469, -0.8928097010248125e-3]);
            s.rk_reference = false;
            Box::new(s)
        }
        "robertson" => {
            let mut s = spec(
                "robertson",
                "Robertson (k = 0.04, 3e7, 1e4), y0 = (1, 0, 0), t in [0, 1e11]; reference from the Test Set (ROBER)",
                Problem::new(robertson(), vector![1.0, 0.0, 0.0], (0.0, 1e11)),
                None,
                (vec![], vec![]),
            );
            #[allow(clippy::excessive_precision)] // digits as published
            let reference = vector![2.083340149701255e-8, 8.333360770334713e-14, 0.9999999791665050];
            s.reference_end = Some(reference);
            s.rk_reference = false;
            s.atol_over_rtol = 1e-4;
            Box::new(s)
        }
        "orego" => {
            let mut s = spec(
                "orego",
                "Oregonator (s = 77.27, q = 8.375e-6, w = 0.161), y0 = (1, 2, 3), t in [0, 360]; reference from the Test Set (OREGO)",
                Problem::new(orego(), vector![1.0, 2.0, 3.0], (0.0, 360.0)),
                None,
                (vec![], vec![]),
            );
            s.reference_end = Some(OREGO_REF_360.into());
            s.rk_reference = false;
            Box::new(s)
        }
        "hires" => {
            let mut s = spec(
                "hires",
                "HIRES (8 reactions of photomorphogenesis), t in [0, 321.8122]; reference from the Test Set",
                Problem::new(hires(), hires_y0(), (0.0, HIRES_T)),
                None,
                (vec![], vec![]),
            );
            s.reference_end = Some(HIRES_REF.into());
            s.rk_reference = false;
            Box::new(s)
        }
        "brusselator" => {
            let n = 20;
            let s = spec(
                "brusselator",
                "1-D Brusselator, 20 grid points (40 unknowns, DVector with faer LU), t in [0, 10]; reference RK45 at 1e-12",
                Problem::new(brusselator(n), brusselator_y0(n), (0.0, 10.0)),
                None::<ExactFn<nalgebra::Dyn>>,
                (halvings(0.004, 5), halvings(0.05, 4)),
            );
            Box::new(s)
        }
        _ => return Err(unknown()),
    })
}

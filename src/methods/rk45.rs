//! Dormand–Prince 5(4) (Dormand & Prince 1980; Hairer–Nørsett–Wanner, ODE I §II.5,
//! `dopri5.f`): seven stages with FSAL, embedded 4th-order estimate, Shampine's
//! 4th-order dense output, and Hairer's stiffness test.

use super::{Method, Outcome, Step, Stepper};
use crate::error::Result;
use crate::methods::step_size::Controller;
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// The Butcher tableau as the paper prints it.
pub mod tableau {
    /// Nodes `c`.
    pub const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
    /// Coefficients `a_ij` (row `i`, lower triangle).
    pub const A: [[f64; 6]; 7] = [
        [0.0; 6],
        [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
        [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
        [
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
            0.0,
            0.0,
        ],
        [
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
            0.0,
        ],
        [
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
        ],
    ];
    /// 5th-order weights `b` (= last row of `A`: FSAL).
    pub const B: [f64; 7] = [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
        0.0,
    ];
    /// Embedded 4th-order weights `b̂`.
    pub const B_HAT: [f64; 7] = [
        5179.0 / 57600.0,
        0.0,
        7571.0 / 16695.0,
        393.0 / 640.0,
        -92097.0 / 339200.0,
        187.0 / 2100.0,
        1.0 / 40.0,
    ];
    /// Error weights `e = b − b̂` (Hairer's sign).
    pub const E: [f64; 7] = [
        71.0 / 57600.0,
        0.0,
        -71.0 / 16695.0,
        71.0 / 1920.0,
        -17253.0 / 339200.0,
        22.0 / 525.0,
        -1.0 / 40.0,
    ];
    /// Shampine's dense-output weights `d` (Hairer's CONTD5 `r5 = h Σ d_i k_i`).
    pub const D: [f64; 7] = [
        -12715105075.0 / 11282082432.0,
        0.0,
        87487479700.0 / 32700410799.0,
        -10690763975.0 / 1880347072.0,
        701980252875.0 / 199316789632.0,
        -1453857185.0 / 822651844.0,
        69997945.0 / 29380423.0,
    ];
}

use tableau::{A, C, D as DW, E};

/// Dormand–Prince 5(4): `x₁ = x₀ + h Σ bᵢ kᵢ`, error `h Σ eᵢ kᵢ`, FSAL (`k₇ = f(t₁, x₁)`
/// is the next step's `k₁`), six new `f` evaluations per step.
///
/// ```
/// use reckon::{model, methods::Rk45, Options, Problem};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let sol = Problem::new(&f, vector![1.0], (0.0, 1.0)).solve(Rk45, &Options::default().rtol(1e-10).atol(1e-12)).unwrap();
/// assert!((sol.last().1[0] - (-1.0f64).exp()).abs() < 1e-10);
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct Rk45;

/// [`Rk45`]'s run: the stage derivatives `k₁…k₇` and stage arguments (inline for fixed
/// sizes), and whether `k₁` holds `f(t, x)` for the next step (FSAL).
#[derive(Debug, Clone)]
pub struct Rk45Stepper<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    k: [OVector<f64, D>; 7],
    y: OVector<f64, D>,
    y6: OVector<f64, D>,
    fsal: bool,
}

impl<D: Dim> Method<D> for Rk45
where
    DefaultAllocator: Allocator<D>,
{
    type Stepper = Rk45Stepper<D>;
    fn name(&self) -> &'static str {
        "rk45"
    }
    fn order(&self) -> u32 {
        5
    }
    fn error_order(&self) -> Option<u32> {
        Some(4)
    }
    fn controller(&self) -> Controller {
        Controller::new(4, 0.04)
    }
    fn stepper<S: System<D>>(self, f: &mut Eval<'_, D, S>, t0: f64, x0: &OVector<f64, D>) -> Result<Rk45Stepper<D>> {
        let mut s = Rk45Stepper {
            k: std::array::from_fn(|_| x0.clone()),
            y: x0.clone(),
            y6: x0.clone(),
            fsal: true,
        };
        f.rhs(t0, x0, &mut s.k[0])?;
        Ok(s)
    }
}

impl<D: Dim> Stepper<D> for Rk45Stepper<D>
where
    DefaultAllocator: Allocator<D>,
{
    fn derivative_at_start(&self) -> Option<&OVector<f64, D>> {
        self.fsal.then_some(&self.k[0])
    }
    #[inline(always)]
    fn step<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, s: Step<'_, D>) -> Result<Outcome> {
        let Step {
            t,
            x,
            h,
            x_new,
            w,
            adaptive,
        } = s;
        let Rk45Stepper { k, y, y6, fsal } = self;
        let [k1, k2, k3, k4, k5, k6, k7] = k;
        if !*fsal {
            refresh_k1(f, t, x, k1);
            *fsal = true;
        }
        let n = x.len();
        // stage arguments written out as in the paper; slices of equal, known length
        // let the compiler drop bounds checks and keep the loops tight
        macro_rules! stage {
            ($out:expr, $a0:expr, $k0:expr $(, $a:expr, $k:expr)*) => {{
                let o = &mut $out.as_mut_slice()[..n];
                let xs = &x.as_slice()[..n];
                let k0 = &$k0.as_slice()[..n];
                for i in 0..n {
                    o[i] = xs[i] + h * ($a0 * k0[i] $(+ $a * $k.as_slice()[i])*);
                }
            }};
        }
        stage!(y, A[1][0], k1);
        f.rhs_uncounted(t + C[1] * h, y, k2);
        stage!(y, A[2][0], k1, A[2][1], k2);
        f.rhs_uncounted(t + C[2] * h, y, k3);
        stage!(y, A[3][0], k1, A[3][1], k2, A[3][2], k3);
        f.rhs_uncounted(t + C[3] * h, y, k4);
        stage!(y, A[4][0], k1, A[4][1], k2, A[4][2], k3, A[4][3], k4);
        f.rhs_uncounted(t + C[4] * h, y, k5);
        stage!(y6, A[5][0], k1, A[5][1], k2, A[5][2], k3, A[5][3], k4, A[5][4], k5);
        f.rhs_uncounted(t + h, y6, k6);
        stage!(x_new, A[6][0], k1, A[6][2], k3, A[6][3], k4, A[6][4], k5, A[6][5], k6);
        f.rhs_uncounted(t + h, x_new, k7);
        f.stats.rhs_evals += 6;
        if !adaptive {
            return Ok(Outcome::Done { err: 0.0 });
        }
        let (k1, k3, k4, k5, k6, k7) = (
            k1.as_slice(),
            k3.as_slice(),
            k4.as_slice(),
            k5.as_slice(),
            k6.as_slice(),
            k7.as_slice(),
        );
        // the error estimate covers the controlled components only; the others are
        // watched (the sensitivities of an augmented solve)
        if w.controlled < n {
            w.rest_from(
                |i| h * (E[0] * k1[i] + E[2] * k3[i] + E[3] * k4[i] + E[4] * k5[i] + E[5] * k6[i] + E[6] * k7[i]),
                x.as_slice(),
                x_new.as_slice(),
            );
            let m = w.controlled;
            w.raise_uncontrolled(growth_error(
                h,
                &k7[m..],
                &k6[m..],
                &x_new.as_slice()[m..],
                &y6.as_slice()[m..],
            ));
        }
        macro_rules! sum {
            ($n:expr) => {{
                let n = $n;
                let (xs, xn) = (&x.as_slice()[..n], &x_new.as_slice()[..n]);
                let (rtol, atol) = (&w.rtol.as_slice()[..n], &w.atol.as_slice()[..n]);
                let mut s = 0.0;
                for i in 0..n {
                    let e =
                        h * (E[0] * k1[i] + E[2] * k3[i] + E[3] * k4[i] + E[4] * k5[i] + E[5] * k6[i] + E[6] * k7[i]);
                    // (a component held at exactly 0 with atol = 0 has scale 0: keep 0/0 out)
                    let sk = (atol[i] + rtol[i] * xs[i].abs().max(xn[i].abs())).max(f64::MIN_POSITIVE);
                    s += (e / sk) * (e / sk);
                }
                s
            }};
        }
        // all components (the default) as a loop of the state's length, which a
        // fixed-size state knows at compile time (the run-time count cost 2–8 % of
        // RK45's instructions: 1.05× the hand-written loop instead of 0.93–1.04×)
        let (s, n) = if w.controlled >= n {
            (sum!(n), n)
        } else {
            (sum!(w.controlled), w.controlled)
        };
        Ok(Outcome::Done {
            err: (s / n as f64).sqrt(),
        })
    }
    /// The first stage derivative (in evaluation order) that is not finite.
    fn diagnose<S: System<D>>(
        &mut self,
        _f: &mut Eval<'_, D, S>,
        t: f64,
        _x: &OVector<f64, D>,
        h: f64,
        x_new: &OVector<f64, D>,
    ) -> crate::Error {
        for (i, k) in self.k.iter().enumerate() {
            if let Err(e) = crate::model::finite(k.as_slice(), t + C[i] * h, crate::error::Quantity::Derivative) {
                return e;
            }
        }
        crate::model::finite(x_new.as_slice(), t + h, crate::error::Quantity::State)
            .err()
            .unwrap_or(crate::Error::NonFinite {
                t: t + h,
                quantity: crate::error::Quantity::State,
                component: 0,
            })
    }
    fn accept(&mut self) {
        // a swap: k₇ = f(t₁, x₁) is the next step's k₁, and the accepted step's own
        // k₁ stays readable in k₇'s slot (which the next step overwrites) for
        // [`Rk45Stepper::stages`]
        let [k1, .., k7] = &mut self.k;
        std::mem::swap(k1, k7);
    }
    fn reset(&mut self) {
        self.fsal = false;
    }
    fn dense_len(&self) -> usize {
        5
    }
    /// `x(t + θh) = r₁ + θ(r₂ + (1−θ)(r₃ + θ(r₄ + (1−θ)r₅)))` (Hairer's CONTD5), stored in
    /// powers of θ: `c₀ = r₁, c₁ = r₂ + r₃, c₂ = r₄ + r₅ − r₃, c₃ = −r₄ − 2r₅, c₄ = r₅`.
    fn dense<S: System<D>>(
        &mut self,
        _f: &mut Eval<'_, D, S>,
        _t: f64,
        h: f64,
        x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
        c: &mut [OVector<f64, D>],
    ) -> Result<()> {
        let k = &self.k;
        for i in 0..x.len() {
            let r = contd5(h, x[i], x_new[i], |j| k[j][i]);
            for (cp, rp) in c.iter_mut().zip(r) {
                cp[i] = rp;
            }
        }
        Ok(())
    }
    /// Hairer's test `h·λ ≈ |h|·‖k₇ − k₆‖ / ‖x₁ − y₆‖` (both stages at `t + h`).
    fn stiffness(&self, h: f64, x_new: &OVector<f64, D>) -> Option<f64> {
        let num = (&self.k[6] - &self.k[5]).norm();
        let den = (x_new - &self.y6).norm();
        (den > 0.0).then(|| h.abs() * num / den)
    }
}

impl<D: Dim> Rk45Stepper<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// The stage derivatives `k₁…k₇` of the last accepted step, in order: what a scheme
    /// differentiating the step needs (the staggered sensitivities of
    /// [`crate::sensitivity`]). Valid after an accepted step, until the next step.
    pub(crate) fn stages(&self) -> [&OVector<f64, D>; 7] {
        let [k7, k2, k3, k4, k5, k6, k1] = self.k.each_ref();
        [k1, k2, k3, k4, k5, k6, k7]
    }
}

/// One component's dense-output coefficients in powers of θ (Hairer's CONTD5,
/// `r₁ + θ(r₂ + (1−θ)(r₃ + θ(r₄ + (1−θ)r₅)))`) from the step's ends `x₀`, `x₁` and its
/// stage derivatives `k(j)`, `j = 0…6`: `[r₁, r₂ + r₃, r₄ + r₅ − r₃, −r₄ − 2r₅, r₅]`.
#[inline(always)]
pub(crate) fn contd5(h: f64, x0: f64, x1: f64, k: impl Fn(usize) -> f64) -> [f64; 5] {
    let r1 = x0;
    let r2 = x1 - x0;
    let r3 = h * k(0) - r2;
    let r4 = r2 - h * k(6) - r3;
    let r5 = h * (0..7).map(|j| DW[j] * k(j)).sum::<f64>();
    [r1, r2 + r3, r4 + r5 - r3, -r4 - 2.0 * r5, r5]
}

/// `k₁ ← f(t, x)` after a discontinuity. Kept out of line: inlined, the compiler
/// hoists the (pure) math of `f` above the FSAL test and evaluates it on every step.
#[cold]
#[inline(never)]
fn refresh_k1<D: Dim, S: System<D>>(f: &mut Eval<'_, D, S>, t: f64, x: &OVector<f64, D>, k1: &mut OVector<f64, D>)
where
    DefaultAllocator: Allocator<D>,
{
    f.rhs_unchecked(t, x, k1);
}

/// The relative error of one Dormand–Prince step on the growing mode the stage
/// derivatives show, `|R(z)·e^{−z} − 1|` with `R(z) = Σ_{k≤5} z^k/k! + z⁶/600` and
/// `z = h·λ`, `λ` the Rayleigh quotient `⟨k₇ − k₆, y₇ − y₆⟩/‖y₇ − y₆‖²` of the last two
/// stages (both at `t + h`; dopri5.f's stiffness test takes the same pair); 0 for a
/// decaying mode. The embedded estimate fails far outside the method's accuracy region
/// (at `z = 6.3` it reads under 10 % where the step is 41 % short of `e^z`); this does
/// not. For the watched components of a sensitivity solve
/// ([`Weights::uncontrolled`](crate::methods::step_size::Weights::uncontrolled)).
pub(crate) fn growth_error(h: f64, k7: &[f64], k6: &[f64], y7: &[f64], y6: &[f64]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..k7.len() {
        let dy = y7[i] - y6[i];
        num += (k7[i] - k6[i]) * dy;
        den += dy * dy;
    }
    let z = h * num / den;
    if !(den > 0.0 && z > 0.0) {
        return 0.0;
    }
    if z > 700.0 {
        return f64::INFINITY;
    }
    let r = 1.0 + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z * (1.0 / 24.0 + z * (1.0 / 120.0 + z / 600.0)))));
    (r * (-z).exp() - 1.0).abs()
}

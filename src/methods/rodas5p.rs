//! Rodas5P: Steinebach's (2023) stiffly accurate, L-stable Rosenbrock method of order 5
//! with an embedded method of order 4 and a dense output of order 4.

use super::iteration::IterationMatrix;
use super::{Failure, Method, Outcome, Step, Stepper};
use crate::error::Result;
use crate::linalg::LuDim;
use crate::methods::step_size::{Controller, Weights};
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, OVector};

/// Number of stages.
pub const STAGES: usize = 8;
/// Diagonal `γ` of the Rosenbrock matrix.
pub const GAMMA: f64 = 0.21193756319429014;
/// `a_ij` of the transformed form, `U_i = x + Σ_j a_ij k_j`; rows 7 and 8 are
/// `U_7 = U_6 + k_6`, `U_8 = U_7 + k_7` (stiffly accurate: `x₁ = U_8 + k_8`).
pub const A: [[f64; 7]; 8] = [
    [0.0; 7],
    [3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [2.849394379747939, 0.45842242204463923, 0.0, 0.0, 0.0, 0.0, 0.0],
    [
        -6.954028509809101,
        2.489845061869568,
        -10.358996098473584,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        2.8029986275628964,
        0.5072464736228206,
        -0.3988312541770524,
        -0.04721187230404641,
        0.0,
        0.0,
        0.0,
    ],
    [
        -7.502846399306121,
        2.561846144803919,
        -11.627539656261098,
        -0.18268767659942256,
        0.030198172008377946,
        0.0,
        0.0,
    ],
    [
        -7.502846399306121,
        2.561846144803919,
        -11.627539656261098,
        -0.18268767659942256,
        0.030198172008377946,
        1.0,
        0.0,
    ],
    [
        -7.502846399306121,
        2.561846144803919,
        -11.627539656261098,
        -0.18268767659942256,
        0.030198172008377946,
        1.0,
        1.0,
    ],
];
/// `C_ij` of the transformed form (the stage right-hand side gets `Σ_j (C_ij/h) k_j`).
pub const C: [[f64; 7]; 8] = [
    [0.0; 7],
    [-14.155112264123755, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [-17.97296035885952, -2.859693295451294, 0.0, 0.0, 0.0, 0.0, 0.0],
    [
        147.12150275711716,
        -1.41221402718213,
        71.68940251302358,
        0.0,
        0.0,
        0.0,
        0.0,
    ],
    [
        165.43517024871676,
        -0.4592823456491126,
        42.90938336958603,
        -5.961986721573306,
        0.0,
        0.0,
        0.0,
    ],
    [
        24.854864614690072,
        -3.0009227002832186,
        47.4931110020768,
        5.5814197821558125,
        -0.6610691825249471,
        0.0,
        0.0,
    ],
    [
        30.91273214028599,
        -3.1208243349937974,
        77.79954646070892,
        34.28646028294783,
        -19.097331116725623,
        -28.087943162872662,
        0.0,
    ],
    [
        37.80277123390563,
        -3.2571969029072276,
        112.26918849496327,
        66.9347231244047,
        -40.06618937091002,
        -54.66780262877968,
        -9.48861652309627,
    ],
];
/// Stage times `t + c_i h`.
pub const C_T: [f64; 8] = [
    0.0,
    0.6358126895828704,
    0.4095798393397535,
    0.9769306725060716,
    0.4288403609558664,
    1.0,
    1.0,
    1.0,
];
/// `d_i = Σ_j γ_ij`: stage `i` gets `d_i·h·∂f/∂t`.
pub const D_T: [f64; 8] = [
    0.21193756319429014,
    -0.42387512638858027,
    -0.3384627126235924,
    1.8046452872882734,
    2.325825639765069,
    0.0,
    0.0,
    0.0,
];
/// Dense output: `K_r = Σ_j H[r][j] k_j`, `x(t+θh) = (1−θ)x₀ + θ(x₁ + (1−θ)(K₁ + θ(K₂ + θK₃)))`.
pub const H: [[f64; 8]; 3] = [
    [
        25.948786856663858,
        -2.5579724845846235,
        10.433815404888879,
        -2.3679251022685204,
        0.524948541321073,
        1.1241088310450404,
        0.4272876194431874,
        -0.17202221070155493,
    ],
    [
        -9.91568850695171,
        -0.9689944594115154,
        3.0438037242978453,
        -24.495224566215796,
        20.176138334709044,
        15.98066361424651,
        -6.789040303419874,
        -6.710236069923372,
    ],
    [
        11.419903575922262,
        2.8879645146136994,
        72.92137995996029,
        80.12511834622643,
        -52.072871366152654,
        -59.78993625266729,
        -0.15582684282751913,
        4.883087185713722,
    ],
];

/// [`Rodas5P`]'s run: the stages, the linearisation and the LU of `W`.
pub struct Rodas5PStepper<D: LuDim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    k: [OVector<f64, D>; STAGES],
    u: OVector<f64, D>,
    fx: OVector<f64, D>,
    dfdt: OVector<f64, D>,
    /// `(t, x)` at which `fx`, `dfdt` and `J` were evaluated (reused after a rejection).
    x_at: OVector<f64, D>,
    t_at: f64,
    /// `Σ_j (C_ij/h)·k_j` of a stage, multiplied by the mass matrix when there is one.
    cm: OVector<f64, D>,
    /// `J` and the LU of `W = I/(hγ) − J`, dense or sparse as the run chose.
    lin: IterationMatrix<D>,
}

/// Rodas5P (Steinebach 2023), a linearly implicit Runge–Kutta (Rosenbrock) method:
/// with `J = ∂f/∂x(t₀, x₀)`, `f_t = ∂f/∂t(t₀, x₀)` and `W = I/(hγ) − J`, eight stages
///
/// `W k_i = f(t₀ + c_i h, x₀ + Σ_{j<i} a_ij k_j) + d_i h f_t + Σ_{j<i} (C_ij/h) k_j`,
///
/// `x₁ = x₀ + Σ_{j≤5} a_6j k_j + k_6 + k_7 + k_8`, with the embedded (order 4) solution
/// `x₀ + … + k_7` (error estimate `k_8`). Order 5, stiffly accurate (`x₁` is the last
/// stage's argument plus its increment), L-stable (`R(∞) = 0`). No Newton iteration:
/// one Jacobian, one LU of `W` and 8 `f` calls per step (after a rejection the
/// Jacobian and `f(t₀, x₀)` are reused, only `W` is refactored).
///
/// The method is only order 5 with the exact Jacobian, which reckon's models give by
/// automatic differentiation. `∂f/∂t` comes from [`System::time_derivative`]; a model
/// that cannot provide it gets a forward difference in `t`,
/// `(f(t₀ + δ, x₀) − f(t₀, x₀))/δ` with `δ = √ε·max(1, |t₀|)` (one more `f` call per step;
/// exactly 0 for an autonomous model, about 8 digits otherwise), used for that term only.
///
/// **Controller**: Hairer's PI controller for an order-4 estimate (`β = 0.04`). The LU is
/// refactored on every step anyway, so changing `h` costs nothing and no "hold" band is
/// used; the PI memory damps the step-size oscillations of stiff transients.
///
/// **Dense output** (order 4): `x(t₀+θh) = (1−θ)x₀ + θ(x₁ + (1−θ)(K₁ + θ(K₂ + θK₃)))`,
/// `K_r = Σ_j H_rj k_j`.
///
/// ```
/// use reckon::{model, methods::Rodas5P, Options, Problem};
/// use nalgebra::vector;
/// // stiff linear decay towards cos t: x' = −1000(x − cos t), x(0) = 1;
/// // `t: S` gives Rodas5P the exact ∂f/∂t = −1000 sin t by autodiff
/// let f = model!(|t: S, x: [S; 1]| vector![(x[0] - t.cos()) * -1000.0]);
/// let sol = Problem::new(&f, vector![1.0], (0.0, 1.0))
///     .solve(Rodas5P, &Options::default().rtol(1e-8).atol(1e-10))
///     .unwrap();
/// // x(t) ≈ cos t + sin t/1000 up to O(1e-6)
/// let exact = (1e6 * 1f64.cos() + 1e3 * 1f64.sin()) / (1e6 + 1.0);
/// assert!((sol.last().1[0] - exact).abs() < 1e-8);
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct Rodas5P;

impl<D: LuDim> Method<D> for Rodas5P
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    type Stepper = Rodas5PStepper<D>;
    fn tightens_loose_tolerances(&self) -> bool {
        true
    }
    fn takes_mass(&self) -> bool {
        true
    }
    fn consistent_start<S: System<D>>(
        &self,
        f: &mut Eval<'_, D, S>,
        t0: f64,
        x0: &OVector<f64, D>,
        w: &Weights<D>,
    ) -> Result<Option<OVector<f64, D>>> {
        match f.mass {
            Some(m) => super::consistent::consistent_start(f, m, t0, x0, w),
            None => Ok(None),
        }
    }
    fn crossing_test(&self) -> bool {
        true
    }
    fn name(&self) -> &'static str {
        "rodas5p"
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
    fn stepper<S: System<D>>(
        self,
        f: &mut Eval<'_, D, S>,
        _t0: f64,
        x0: &OVector<f64, D>,
    ) -> Result<Rodas5PStepper<D>> {
        Ok(Rodas5PStepper {
            k: std::array::from_fn(|_| x0.clone()),
            u: x0.clone(),
            fx: x0.clone(),
            dfdt: x0.clone(),
            x_at: x0.clone(),
            t_at: f64::NAN,
            cm: x0.clone(),
            lin: IterationMatrix::new(f, x0)?,
        })
    }
}

impl<D: LuDim> Stepper<D> for Rodas5PStepper<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn reset(&mut self) {
        self.t_at = f64::NAN;
    }
    fn step<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, s: Step<'_, D>) -> Result<Outcome> {
        let Step {
            t,
            x,
            h,
            x_new,
            w: wt,
            adaptive,
        } = s;
        let w = self;
        if !(w.t_at == t && w.x_at == *x) {
            f.rhs(t, x, &mut w.fx)?;
            w.lin.evaluate(f, t, x)?;
            if !f.time_derivative(t, x, &mut w.dfdt)? {
                // forward difference in t, for the d_i·h·f_t term only
                let dt = f64::EPSILON.sqrt() * t.abs().max(1.0);
                let t1 = t + dt;
                let dt = t1 - t;
                f.rhs(t1, x, &mut w.dfdt)?;
                w.dfdt -= &w.fx;
                w.dfdt /= dt;
            }
            w.x_at.copy_from(x);
            w.t_at = t;
        }
        // W = M/(hγ) − J (M = I without a mass matrix)
        let inv_hg = 1.0 / (h * GAMMA);
        f.stats.lu_decompositions += 1;
        if !w.lin.factor(inv_hg, -1.0) {
            return Ok(Outcome::Retry(Failure::Singular));
        }
        let mass = f.mass;
        let Rodas5PStepper {
            k,
            u,
            fx,
            dfdt,
            lin,
            cm,
            ..
        } = w;
        for s in 0..STAGES {
            let (done, rest) = k.split_at_mut(s);
            let ks = &mut rest[0];
            if s == 0 {
                ks.copy_from(fx);
            } else {
                u.copy_from(x);
                for (j, kj) in done.iter().enumerate() {
                    let a = A[s][j];
                    if a != 0.0 {
                        u.axpy(a, kj, 1.0);
                    }
                }
                f.rhs_unchecked(t + C_T[s] * h, u, ks);
                match mass {
                    None => {
                        for (j, kj) in done.iter().enumerate() {
                            ks.axpy(C[s][j] / h, kj, 1.0);
                        }
                    }
                    // M·Σ (C_ij/h)·k_j
                    Some(m) => {
                        cm.fill(0.0);
                        for (j, kj) in done.iter().enumerate() {
                            cm.axpy(C[s][j] / h, kj, 1.0);
                        }
                        m.mul_into(cm.as_slice(), 1.0, 1.0, ks.as_mut_slice());
                    }
                }
            }
            if D_T[s] != 0.0 {
                ks.axpy(D_T[s] * h, dfdt, 1.0);
            }
            lin.solve(ks);
        }
        // x₁ = U_8 + k_8
        x_new.copy_from(u);
        *x_new += &k[7];
        if !adaptive {
            return Ok(Outcome::Done { err: 0.0 });
        }
        Ok(Outcome::Done {
            err: wt.norm(&k[7], x, x_new),
        })
    }
    fn dense_len(&self) -> usize {
        5
    }
    /// In powers of θ: `c₀ = x₀, c₁ = x₁ − x₀ + K₁, c₂ = K₂ − K₁, c₃ = K₃ − K₂, c₄ = −K₃`.
    fn dense<S: System<D>>(
        &mut self,
        _f: &mut Eval<'_, D, S>,
        _t: f64,
        _h: f64,
        x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
        c: &mut [OVector<f64, D>],
    ) -> Result<()> {
        let w = &*self;
        for i in 0..x.len() {
            let kr = |r: usize| (0..STAGES).map(|j| H[r][j] * w.k[j][i]).sum::<f64>();
            let (k1, k2, k3) = (kr(0), kr(1), kr(2));
            c[0][i] = x[i];
            c[1][i] = x_new[i] - x[i] + k1;
            c[2][i] = k2 - k1;
            c[3][i] = k3 - k2;
            c[4][i] = -k3;
        }
        Ok(())
    }
}

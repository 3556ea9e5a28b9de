//! The Jacobian `A = ∂φ_h/∂x` of a discrete step map `x₁ = φ_h(x₀)` by automatic
//! differentiation through the step: the step is run on num-dual numbers with the
//! model's dual instantiation, so `A` is exact for the discretisation actually used.

use crate::error::Result;
use crate::methods::ImplicitEuler;
use crate::methods::rk45::tableau as dp5;
use crate::model::DualSystem;
use crate::{Options, Problem};
use nalgebra::{Const, SMatrix, SVector};
use num_dual::DualSVec64;

/// The discretisation whose step map is linearised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Discretization {
    /// `x₁ = x₀ + h f(t, x₀)`.
    Euler,
    /// One Dormand–Prince 5th-order step.
    Rk45,
    /// `x₁ = x₀ + h f(t + h, x₁)`, solved by Newton; `A = (I − hJ(t+h, x₁))⁻¹` by the
    /// implicit function theorem with the autodiff `J`.
    ImplicitEuler,
}

/// An explicit Butcher tableau by reference.
struct Tableau<'a> {
    a: &'a [&'a [f64]],
    b: &'a [f64],
    c: &'a [f64],
}

/// One explicit Runge–Kutta step on dual numbers: stages use the model's dual copy.
fn rk_dual<const N: usize, S: DualSystem<Const<N>>>(
    sys: &S,
    tab: &Tableau<'_>,
    t: f64,
    x: &SVector<DualSVec64<N>, N>,
    u: &[f64],
    h: f64,
) -> SVector<DualSVec64<N>, N> {
    let Tableau { a, b, c } = tab;
    let mut k: Vec<SVector<DualSVec64<N>, N>> = Vec::with_capacity(b.len());
    for i in 0..b.len() {
        let mut y = *x;
        for (j, kj) in k.iter().enumerate() {
            if a[i][j] != 0.0 {
                y += kj * DualSVec64::<N>::from(h * a[i][j]);
            }
        }
        k.push(sys.rhs_dual(t + c[i] * h, &y, u));
    }
    let mut x1 = *x;
    for (bi, ki) in b.iter().zip(&k) {
        if *bi != 0.0 {
            x1 += ki * DualSVec64::<N>::from(h * bi);
        }
    }
    x1
}

/// `(x₁, A)` for one step of size `h` from `(t, x)` with inputs `u` held.
///
/// ```
/// use reckon::kalman::step::{step_jacobian, Discretization};
/// use reckon::vehicles::unicycle;
/// use nalgebra::vector;
/// let (x1, a) = step_jacobian(&unicycle::model(), Discretization::Euler, 0.0, &vector![0.0, 0.0, 0.3], &[2.0, 0.1], 0.1).unwrap();
/// assert!((x1[0] - 0.2 * 0.3f64.cos()).abs() < 1e-15);
/// assert!((a[(0, 2)] + 0.2 * 0.3f64.sin()).abs() < 1e-15); // ∂x₁/∂θ = −h v sin θ
/// ```
pub fn step_jacobian<const N: usize, S: DualSystem<Const<N>>>(
    sys: &S,
    disc: Discretization,
    t: f64,
    x: &SVector<f64, N>,
    u: &[f64],
    h: f64,
) -> Result<(SVector<f64, N>, SMatrix<f64, N, N>)>
where
    Const<N>: crate::linalg::LuDim,
{
    match disc {
        Discretization::Euler => Ok(num_dual::jacobian(
            |xd: SVector<DualSVec64<N>, N>| {
                rk_dual(
                    sys,
                    &Tableau {
                        a: &[&[0.0]],
                        b: &[1.0],
                        c: &[0.0],
                    },
                    t,
                    &xd,
                    u,
                    h,
                )
            },
            x,
        )),
        Discretization::Rk45 => {
            let rows: Vec<&[f64]> = dp5::A.iter().map(|r| &r[..]).collect();
            Ok(num_dual::jacobian(
                |xd: SVector<DualSVec64<N>, N>| {
                    rk_dual(
                        sys,
                        &Tableau {
                            a: &rows,
                            b: &dp5::B,
                            c: &dp5::C,
                        },
                        t,
                        &xd,
                        u,
                        h,
                    )
                },
                x,
            ))
        }
        Discretization::ImplicitEuler => {
            let controls = crate::Controls::new(vec![t], vec![u.to_vec()])?;
            let p = Problem::new(sys, *x, (t, t + h)).controls(controls);
            let opts = Options::default().fixed(h).rtol(1e-12).atol(1e-14).dense(false);
            let x1 = *p.solve(ImplicitEuler::default(), &opts)?.last().1;
            let (_, j) = num_dual::jacobian(|xd: SVector<DualSVec64<N>, N>| sys.rhs_dual(t + h, &xd, u), &x1);
            let m = SMatrix::<f64, N, N>::identity() - j * h;
            let a = m.try_inverse().ok_or(crate::Error::SingularMatrix { t, h })?;
            Ok((x1, a))
        }
    }
}

/// `(x₁, A)` for an exact (or any closed-form) flow written generically over the scalar:
/// `A` is the flow's Jacobian with respect to the state.
pub fn flow_jacobian<const N: usize>(
    flow: impl Fn(&SVector<DualSVec64<N>, N>) -> SVector<DualSVec64<N>, N>,
    x: &SVector<f64, N>,
) -> (SVector<f64, N>, SMatrix<f64, N, N>) {
    num_dual::jacobian(|xd: SVector<DualSVec64<N>, N>| flow(&xd), x)
}

/// EKF prediction through one step of a model: `x̂ ← φ_h(x̂)`, `Γ ← A·Γ·Aᵀ + Γ_α` with
/// `A = ∂φ_h/∂x` from [`step_jacobian`] (automatic differentiation through the step).
///
/// ```
/// use reckon::kalman::{Kalman, step::{ekf_predict, Discretization}};
/// use reckon::vehicles::unicycle;
/// use nalgebra::{vector, Matrix3};
/// let mut k = Kalman::new(vector![0.0, 0.0, 0.0], Matrix3::identity() * 0.01);
/// ekf_predict(&mut k, &unicycle::model(), Discretization::Rk45, 0.0, &[1.0, 0.0], 1.0, &Matrix3::zeros()).unwrap();
/// assert!((k.x[0] - 1.0).abs() < 1e-15);
/// // heading uncertainty turns into lateral uncertainty: σ_y² = 0.01 + 1²·0.01
/// assert!((k.p[(1, 1)] - 0.02).abs() < 1e-15);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn ekf_predict<const N: usize, S: DualSystem<Const<N>>>(
    kf: &mut super::Kalman<Const<N>>,
    sys: &S,
    disc: Discretization,
    t: f64,
    u: &[f64],
    h: f64,
    q: &SMatrix<f64, N, N>,
) -> Result<()>
where
    Const<N>: crate::linalg::LuDim,
{
    let (x1, a) = step_jacobian(sys, disc, t, &kf.x, u, h)?;
    kf.predict(&a, &(x1 - a * kf.x), q)?;
    kf.x = x1;
    Ok(())
}

//! Sensitivities across a reset: the saltation matrix. At an event `g(τ, x) = 0` with
//! reset `x⁺ = R(τ, x⁻)`, a column `s = ∂x⁻/∂θ` of `S` moves the event time by
//! `∂τ/∂θ = −(g_x·s)/(g_x·f⁻ + g_t)`, and the state after it by
//!
//! `s⁺ = R_x·s + (R_x·f⁻ + R_t − f⁺)·∂τ/∂θ`
//!
//! (`f⁻ = f(τ, x⁻, u⁻)`, `f⁺ = f(τ, x⁺, u⁺)` with the inputs the reset left). The event
//! and reset functions are plain `f64` closures: `g_x`, `g_t`, `R_t` and the products
//! `R_x·v` are central differences (step `∛ε` relative; about 1e-10 relative error, the
//! same order as the augmented Jacobian's second-derivative block).

use crate::model::DualSystem;
use crate::problem::events::Event;
use nalgebra::allocator::Allocator;
use nalgebra::{DVector, DefaultAllocator, Dim, OVector, U1};

/// The event `ev` of the original problem as an event on the stacked state
/// `z = (x, vec S)` (`n` states, `m` columns): the same zero, direction and stop; its reset,
/// if any, applied to `x` and the saltation matrix to every column of `S`.
pub(super) fn on_stacked<'e, D, S>(ev: &'e Event<'_, D>, sys: &'e S, n: usize, m: usize) -> Event<'e, nalgebra::Dyn>
where
    D: Dim,
    S: DualSystem<D>,
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    let x_of =
        move |z: &DVector<f64>| OVector::<f64, D>::from_column_slice_generic(D::from_usize(n), U1, &z.as_slice()[..n]);
    let mut out = Event::<nalgebra::Dyn>::new(move |t, z: &DVector<f64>| (ev.g)(t, &x_of(z))).direction(ev.direction);
    out.stop_at = ev.stop_at;
    if let Some(r) = &ev.reset {
        out = out.reset_with_inputs(move |t, z: &DVector<f64>, u: &mut [f64]| {
            let x = x_of(z);
            let u_before = u.to_vec();
            let xp = r(t, &x, u);
            if xp.len() != n {
                // the driver reports the wrong length
                return DVector::from_column_slice(xp.as_slice());
            }
            let mut zp = z.clone();
            zp.as_mut_slice()[..n].copy_from_slice(xp.as_slice());
            jump_columns(ev, sys, r, t, &x, &xp, &u_before, u, &mut zp.as_mut_slice()[n..], m);
            zp
        });
    }
    out
}

/// The columns `s` (`m` of them, column-major after `x`) replaced by `s⁺`; NaN where the
/// event grazes (`g_x·f⁻ + g_t = 0`: the event time's sensitivity is unbounded).
#[allow(clippy::too_many_arguments)]
fn jump_columns<D, S>(
    ev: &Event<'_, D>,
    sys: &S,
    r: &crate::problem::events::ResetFn<'_, D>,
    t: f64,
    x: &OVector<f64, D>,
    xp: &OVector<f64, D>,
    u_before: &[f64],
    u_after: &[f64],
    cols: &mut [f64],
    m: usize,
) where
    D: Dim,
    S: DualSystem<D>,
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    let n = x.len();
    let d_of = |v: f64| f64::EPSILON.cbrt() * v.abs().max(1.0);
    let mut f_minus = x.clone();
    sys.rhs(t, x, u_before, &mut f_minus);
    let mut f_plus = xp.clone();
    sys.rhs(t, xp, u_after, &mut f_plus);
    // g_x and g_t by central differences
    let g_at = |tt: f64, xx: &OVector<f64, D>| (ev.g)(tt, xx);
    let mut gx = vec![0.0; n];
    let mut xs = x.clone();
    for (j, gj) in gx.iter_mut().enumerate() {
        let d = d_of(x[j]);
        xs[j] = x[j] + d;
        let up = g_at(t, &xs);
        xs[j] = x[j] - d;
        let down = g_at(t, &xs);
        xs[j] = x[j];
        *gj = (up - down) / (2.0 * d);
    }
    let dt = d_of(t);
    let gt = (g_at(t + dt, x) - g_at(t - dt, x)) / (2.0 * dt);
    let rate = (0..n).map(|j| gx[j] * f_minus[j]).sum::<f64>() + gt;
    // R(t', x') with the inputs as they were before the reset (R may change its copy)
    let reset = |tt: f64, xx: &OVector<f64, D>| {
        let mut u = u_before.to_vec();
        r(tt, xx, &mut u)
    };
    // R_x·v by a central difference along v
    let r_x = |v: &OVector<f64, D>| -> OVector<f64, D> {
        let norm = v.amax();
        if norm == 0.0 {
            return v.map(|_| 0.0);
        }
        let d = f64::EPSILON.cbrt() * x.amax().max(1.0) / norm;
        let (mut a, mut b) = (x.clone(), x.clone());
        a.axpy(d, v, 1.0);
        b.axpy(-d, v, 1.0);
        (reset(t, &a) - reset(t, &b)) / (2.0 * d)
    };
    let r_t = (reset(t + dt, x) - reset(t - dt, x)) / (2.0 * dt);
    // the jump that a shift of the event time makes: R_x·f⁻ + R_t − f⁺
    let shift = r_x(&f_minus) + r_t - &f_plus;
    let mut s = x.clone();
    for c in 0..m {
        let col = &mut cols[c * n..(c + 1) * n];
        s.as_mut_slice().copy_from_slice(col);
        let dtau = -(0..n).map(|j| gx[j] * s[j]).sum::<f64>() / rate;
        let sp = r_x(&s) + &shift * dtau;
        for (o, v) in col.iter_mut().zip(sp.iter()) {
            *o = if rate == 0.0 || !rate.is_finite() { f64::NAN } else { *v };
        }
    }
}

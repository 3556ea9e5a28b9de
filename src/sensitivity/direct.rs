//! Sensitivities by a scheme of the method's own on the plain solve's steps (the
//! *staggered direct* schemes): the plain method takes every step at `D`, so `x`, the
//! times and the step count are the plain solve's bit for bit, and after each accepted
//! step the derivative of that step's map is applied to `S`.

use super::{Sensitivities, SensitivityOptions, Split, stacked_start};
use crate::error::{Error, Result};
use crate::integrator::save::{Saver, needs_dense};
use crate::linalg::{Lu, LuDim};
use crate::methods::rk45::{contd5, tableau};
use crate::methods::{ImplicitEuler, Rk45};
use crate::model::DualSystem;
use crate::problem::Problem;
use crate::problem::options::Options;
use nalgebra::allocator::Allocator;
use nalgebra::{DVector, DefaultAllocator, Dim, Dyn, OMatrix, OVector, U1};

/// The staggered direct scheme for implicit Euler (Caracotsios & Stewart 1985): the plain
/// solve's steps, and after each accepted step `x₁ = x₀ + h·f(t + h, x₁)` one linear solve
/// for its derivative, `(I − h·J(x₁))·S₁ = S₀ + h·[0 | ∂f/∂p (x₁)]`, with `J` and `∂f/∂p`
/// exact at the computed `x₁` (one dual evaluation) and `I − h·J` factored once.
pub(super) fn implicit_euler<D: LuDim, S: DualSystem<D>>(
    problem: &Problem<'_, D, S>,
    method: ImplicitEuler,
    opts: &Options,
    sens: &SensitivityOptions,
) -> Result<Sensitivities<D>>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    let n = problem.x0.len();
    let np = problem.system.n_params();
    let (m, x0_cols) = sens.wrt.columns(n, np);
    let r = D::from_usize(n);
    let mut it = problem.integrator(method, opts)?;
    // z = (x, vec S), the stacked state the saver keeps (as the augmented solve's)
    let mut z = stacked_start(problem.x0.as_slice(), m, sens.wrt);
    let mut out = Saver::<Dyn, _>::with_store(&opts.save, it.direction(), problem.t0, &z, Split::<D>::new(n, m));
    let at_times = needs_dense(&opts.save);
    // the step's linear interpolant in z (implicit Euler's dense output, c₀ + θ·c₁)
    let mut dense = [z.clone(), DVector::zeros(z.len())];
    let mut seg = (problem.t0, 0.0);
    // [I | 0] → [J | ∂f/∂p]: one dual evaluation with n + n_p directions
    let mut unit = vec![0.0; n * (n + np)];
    for i in 0..n {
        unit[i + i * n] = 1.0;
    }
    let mut jp = vec![0.0; n * (n + np)];
    let mut mat = OMatrix::<f64, D, D>::zeros_generic(r, r);
    let mut col = OVector::<f64, D>::zeros_generic(r, U1);
    let mut u = Vec::with_capacity(it.held_inputs().len());
    let mut extra = 0u64;
    // S's error estimate as implicit Euler's own for x, (I − hJ)⁻¹·½(S₁ − S₀ − h·Ṡ₀),
    // relative to S's largest magnitude (adaptive runs, S outside the error control): Ṡ₀ =
    // J·S + [0 | ∂f/∂p] at the step's start, the last step's J(x₁)·S₁ + ∂f/∂p(x₁) when
    // the inputs held on (no evaluation), else one dual evaluation
    let watch = it.is_adaptive();
    let atol = opts.atol.expand("atol", r)?;
    let scales = super::column_scales(problem.x0.as_slice(), problem.system.params(), sens.wrt);
    let mut sdot = vec![0.0; n * m];
    let mut sdot_inputs: Option<Vec<f64>> = None;
    let mut s0 = vec![0.0; n * m];
    let mut x_prev = vec![0.0; n];
    loop {
        u.clear();
        u.extend_from_slice(it.held_inputs());
        let accepted = it.accepted();
        if it.step()?.is_none() {
            break;
        }
        if it.accepted() > accepted {
            let (t, h, _) = it.last_step();
            if watch && sdot_inputs.as_deref() != Some(&u[..]) {
                // z still holds the step's start (x₀, S₀)
                let x0 = OVector::<f64, D>::from_column_slice_generic(r, U1, &z.as_slice()[..n]);
                problem.system.tangent(t, &x0, &u, &z.as_slice()[n..], m, &mut sdot);
                extra += 1;
            }
            let x1 = it.x();
            // the time implicit Euler evaluated f at
            let t1 = t + h;
            problem.system.tangent(t1, x1, &u, &unit, n + np, &mut jp);
            for c in 0..n {
                for i in 0..n {
                    mat[(i, c)] = -h * jp[i + c * n];
                }
                mat[(c, c)] += 1.0;
            }
            extra += 1;
            let lu = D::Lu::factor(&mat).ok_or(Error::SingularMatrix { t, h })?;
            if at_times {
                dense[0].copy_from(&z);
            }
            if watch {
                x_prev.copy_from_slice(&z.as_slice()[..n]);
            }
            let sz = &mut z.as_mut_slice()[n..];
            if watch {
                s0.copy_from_slice(sz);
            }
            for k in 0..m {
                let s_col = &mut sz[k * n..(k + 1) * n];
                col.as_mut_slice().copy_from_slice(s_col);
                if k >= x0_cols {
                    let fp = &jp[(n + k - x0_cols) * n..(n + k - x0_cols + 1) * n];
                    for i in 0..n {
                        col[i] += h * fp[i];
                    }
                }
                lu.solve_in_place(&mut col)?;
                s_col.copy_from_slice(col.as_slice());
            }
            if watch {
                // relative to S's largest magnitude, with Weights::uncontrolled's floor
                let big = s0.iter().chain(sz.iter()).fold(0.0f64, |a, v| a.max(v.abs()));
                let mut sum = 0.0;
                for (k, scale) in scales.iter().enumerate() {
                    for i in 0..n {
                        let j = k * n + i;
                        col[i] = 0.5 * (sz[j] - s0[j] - h * sdot[j]);
                    }
                    lu.solve_in_place(&mut col)?;
                    for i in 0..n {
                        let x = x_prev[i].abs().max(x1[i].abs());
                        let floor = (x + atol[i]) / scale;
                        sum += (col[i] / (big + floor).max(f64::MIN_POSITIVE)).powi(2);
                    }
                }
                let ratio = (sum / (n * m).max(1) as f64).sqrt();
                if ratio > super::UNRESOLVED {
                    return Err(Error::SensitivityUnresolved { t, h, ratio });
                }
                // Ṡ₁ = J(x₁)·S₁ + [0 | ∂f/∂p (x₁)], the next step's Ṡ₀ while the inputs hold
                for k in 0..m {
                    for i in 0..n {
                        let mut acc = if k >= x0_cols {
                            jp[(n + k - x0_cols) * n + i]
                        } else {
                            0.0
                        };
                        for c in 0..n {
                            acc += jp[i + c * n] * sz[k * n + c];
                        }
                        sdot[k * n + i] = acc;
                    }
                }
                sdot_inputs = Some(u.clone());
            }
            z.rows_mut(0, n).copy_from_slice(x1.as_slice());
            crate::model::finite(z.as_slice(), t1, crate::error::Quantity::State)?;
            if at_times {
                let [c0, c1] = &mut dense;
                c1.copy_from(&z);
                *c1 -= &*c0;
            }
            seg = (t, h);
        } else {
            // a stop landed on without a step: the same state, a new time
            z.rows_mut(0, n).copy_from_slice(it.x().as_slice());
        }
        out.step(it.t(), &z, at_times.then_some((seg.0, seg.1, &dense[..])));
    }
    let mut stats = it.stats();
    stats.jacobian_evals += extra;
    stats.lu_decompositions += extra;
    let (t, split) = out.finish();
    Ok(split.into_sensitivities(t, sens.wrt, np, stats, "implicit-euler"))
}

/// The staggered direct scheme for Dormand–Prince 5(4) (internal differentiation of the
/// steps taken): after each accepted step `x₁ = x₀ + h Σ bᵢ kᵢ`, with the plain kernel's
/// own stages `kᵢ = f(t + cᵢh, Yᵢ)` and `Yᵢ = x₀ + h Σ aᵢⱼ kⱼ` (rebuilt from them, bit for
/// bit), the stage sensitivities `Kᵢ = J(Yᵢ)·(S₀ + h Σ aᵢⱼ Kⱼ) + [0 | ∂f/∂p (Yᵢ)]` (one
/// dual evaluation each, [`DualSystem::tangent`]) and `S₁ = S₀ + h Σ bᵢ Kᵢ`. `K₇` at
/// `(t + h, x₁, S₁)` is the next step's `K₁` (first same as last, as `k₇` is), so a step
/// costs six dual evaluations and a rejected attempt none. At output times `S` takes
/// the step's CONTD5 polynomial, as `x` does.
pub(super) fn dopri5<D: Dim, S: DualSystem<D>>(
    problem: &Problem<'_, D, S>,
    opts: &Options,
    sens: &SensitivityOptions,
) -> Result<Sensitivities<D>>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    use tableau::{A, B, C, E};
    // the last stage argument is the step's end (FSAL), so S₁ is the last stage's S
    debug_assert_eq!(A[6][..6], B[..6]);
    let n = problem.x0.len();
    let np = problem.system.n_params();
    let (m, _) = sens.wrt.columns(n, np);
    let nm = n * m;
    let r = D::from_usize(n);
    let mut it = problem.integrator(Rk45, opts)?;
    let mut z = stacked_start(problem.x0.as_slice(), m, sens.wrt);
    let mut out = Saver::<Dyn, _>::with_store(&opts.save, it.direction(), problem.t0, &z, Split::<D>::new(n, m));
    let at_times = needs_dense(&opts.save);
    let mut dense = if at_times {
        vec![DVector::zeros(z.len()); 5]
    } else {
        Vec::new()
    };
    // the last step's (t₀, h), passed again for a landing without a step (as the plain
    // solve does)
    let mut seg = (problem.t0, 0.0);
    // K₁…K₇ (n × m each, column-major, one after the other), the stage argument's S
    let mut kk: [Vec<f64>; 7] = std::array::from_fn(|_| vec![0.0; nm]);
    let mut sy = vec![0.0; nm];
    // the sixth stage's S argument (at t + h, as the seventh's: the growth check)
    let mut sy6 = vec![0.0; nm];
    let mut y = OVector::<f64, D>::zeros_generic(r, U1);
    let mut x0 = problem.x0.clone();
    // what K₇ was evaluated at: the inputs and f(t₁, x₁), to tell FSAL from a fresh k₁
    let mut k7_prev: Option<OVector<f64, D>> = None;
    let (mut u, mut u_prev) = (Vec::new(), Vec::new());
    let mut tangents = 0u64;
    // adaptive runs without S in the error control watch S's own estimate
    let watch = it.is_adaptive();
    let atol = opts.atol.expand("atol", r)?;
    let scales = super::column_scales(problem.x0.as_slice(), problem.system.params(), sens.wrt);
    loop {
        u.clear();
        u.extend_from_slice(it.held_inputs());
        x0.copy_from(it.x());
        let accepted = it.accepted();
        if it.step()?.is_none() {
            break;
        }
        if it.accepted() == accepted {
            // a stop landed on without a step: the same state, a new time
            z.rows_mut(0, n).copy_from_slice(it.x().as_slice());
            out.step(it.t(), &z, at_times.then_some((seg.0, seg.1, &dense[..])));
            continue;
        }
        let (t, h, _) = it.last_step();
        let k = it.stepper().stages();
        let s0 = &z.as_slice()[n..];
        // K₁: the last step's K₇ when k₁ is its k₇ (same inputs, same value), else fresh
        let fsal = k7_prev.as_ref().is_some_and(|k7| k7 == k[0]) && u == u_prev;
        if fsal {
            let [k1s, .., k7s] = &mut kk;
            k1s.copy_from_slice(k7s);
        } else {
            problem.system.tangent(t, &x0, &u, s0, m, &mut kk[0]);
            tangents += 1;
        }
        let ks = k.map(|v| &v.as_slice()[..n]);
        let (xs, s0) = (&x0.as_slice()[..n], &s0[..nm]);
        // stage i from the stages j before it (those with aᵢⱼ ≠ 0, as the kernel wrote
        // them): Yᵢ = x₀ + h·(aᵢⱼ₀kⱼ₀ + …) in the kernel's order, so bit for bit its
        // argument (x₁ for the last stage), the same combination of the Kⱼ for
        // S₀ + h Σ aᵢⱼ Kⱼ, then Kᵢ at (t + cᵢh, Yᵢ)
        macro_rules! stage {
            ($i:literal; $($j:literal),+) => {{
                combine(&mut y.as_mut_slice()[..n], xs, h, [$(A[$i][$j]),+], [$(&ks[$j][..n]),+]);
                let (done, ahead) = kk.split_at_mut($i);
                combine(&mut sy[..nm], s0, h, [$(A[$i][$j]),+], [$(&done[$j][..nm]),+]);
                problem.system.tangent(t + C[$i] * h, &y, &u, &sy, m, &mut ahead[0]);
                tangents += 1;
            }};
        }
        stage!(1; 0);
        stage!(2; 0, 1);
        stage!(3; 0, 1, 2);
        stage!(4; 0, 1, 2, 3);
        stage!(5; 0, 1, 2, 3, 4);
        if watch {
            sy6.copy_from_slice(&sy);
        }
        stage!(6; 0, 2, 3, 4, 5);
        if watch {
            // S's embedded error estimate h Σ eᵢKᵢ relative to S's largest magnitude, with
            // Weights::uncontrolled's floor
            let big = s0.iter().chain(sy.iter()).fold(0.0f64, |a, v| a.max(v.abs()));
            let x1 = it.x();
            let mut sum = 0.0;
            for q in 0..nm {
                let mut e = 0.0;
                for (j, kj) in kk.iter().enumerate() {
                    e += E[j] * kj[q];
                }
                let i = q % n;
                let floor = (xs[i].abs().max(x1[i].abs()) + atol[i]) / scales[q / n];
                sum += (h * e / (big + floor).max(f64::MIN_POSITIVE)).powi(2);
            }
            // and the step's own error on the growing mode of S (the embedded estimate
            // misses it far outside the accuracy region)
            let growth = crate::methods::rk45::growth_error(h, &kk[6], &kk[5], &sy, &sy6);
            let ratio = (sum / nm.max(1) as f64).sqrt().max(growth);
            if ratio > super::UNRESOLVED {
                return Err(Error::SensitivityUnresolved { t, h, ratio });
            }
        }
        if at_times {
            dense[0].copy_from(&z);
        }
        // S₁ = S₀ + h Σ bᵢ Kᵢ: the last stage argument (the last row of A is b)
        z.as_mut_slice()[n..].copy_from_slice(&sy);
        z.rows_mut(0, n).copy_from_slice(it.x().as_slice());
        crate::model::finite(z.as_slice(), t + h, crate::error::Quantity::State)?;
        // (dense is empty unless output times need it)
        if let [c0, c1, c2, c3, c4] = &mut dense[..] {
            for e in 0..z.len() {
                let (a, b) = (c0[e], z[e]);
                let r = if e < n {
                    contd5(h, a, b, |j| k[j][e])
                } else {
                    let q = e - n;
                    contd5(h, a, b, |j| kk[j][q])
                };
                [c0[e], c1[e], c2[e], c3[e], c4[e]] = r;
            }
        }
        match &mut k7_prev {
            Some(k7) => k7.copy_from(k[6]),
            None => k7_prev = Some(k[6].clone()),
        }
        std::mem::swap(&mut u, &mut u_prev);
        seg = (t, h);
        out.step(it.t(), &z, at_times.then_some((t, h, &dense[..])));
    }
    let mut stats = it.stats();
    stats.rhs_evals += tangents;
    let (t, split) = out.finish();
    Ok(split.into_sensitivities(t, sens.wrt, np, stats, "rk45"))
}

/// `out = base + h·(a₀k₀ + a₁k₁ + …)`, summed left to right as Rk45's kernel writes a
/// stage argument (so the same bits for `x`). The callers slice every argument to the
/// length of `out`, which lets the compiler drop the bounds checks of the unrolled terms.
#[inline(always)]
fn combine<const J: usize>(out: &mut [f64], base: &[f64], h: f64, a: [f64; J], k: [&[f64]; J]) {
    for e in 0..out.len() {
        let mut acc = a[0] * k[0][e];
        for j in 1..J {
            acc += a[j] * k[j][e];
        }
        out[e] = base[e] + h * acc;
    }
}

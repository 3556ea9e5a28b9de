//! The commutator-free Lie-group method of order 4 of Celledoni, Marthinsen and Owren,
//! "Commutator-free Lie group methods", Future Gener. Comput. Syst. 19 (2003), eq. (9):
//! the classical RK4's stages with products of exponentials instead of `dexp⁻¹`.

use super::{Method, Outcome, Step, Stepper};
use crate::error::Result;
use crate::lie::Layout;
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// CF4 (Celledoni–Marthinsen–Owren 2003), written for `Ẏ = Y·ξ(t, Y)` (for the left
/// form every `Y·Exp(·)` below reads `Exp(·)·Y`), with `Fᵢ = h·ξ(t₀ + cᵢh, Yᵢ)`,
/// `c = (0, ½, ½, 1)`:
///
/// `Y₁ = Y₀`, `Y₂ = Y₀·Exp(F₁/2)`, `Y₃ = Y₀·Exp(F₂/2)`, `Y₄ = Y₂·Exp(F₃ − F₁/2)`,
/// `Y_½ = Y₀·Exp((3F₁ + 2F₂ + 2F₃ − F₄)/12)`, `Y₁ = Y_½·Exp((−F₁ + 2F₂ + 2F₃ + 3F₄)/12)`.
///
/// Order 4, four `f` calls and six exponentials a step, no `dexp⁻¹` and no commutator;
/// on the vector components it is the classical RK4. Fixed step only: it has no
/// embedded estimate. A constant twist is integrated exactly (`Exp(hξ/2)·Exp(hξ/2)`).
/// Dense output is the cubic Hermite through both ends and both slopes. The rotations
/// of each result get one polar step ([`Layout::project`]) against rounding.
///
/// ```
/// use reckon::{methods::Cf4, vehicles::rigid_body, lie::So3, Options, Problem, StepSize};
/// use nalgebra::vector;
/// let (r0, w0) = (So3::exp(&vector![0.3, -0.2, 0.5]), vector![0.6, -0.3, 1.0]);
/// let f = rigid_body::model([2.0, 2.0, 3.0]);
/// let sol = Problem::new(&f, rigid_body::state(&r0, &w0), (0.0, 5.0))
///     .solve(Cf4::new(rigid_body::layout()), &Options::default().step(StepSize::Fixed(0.01)))
///     .unwrap();
/// let (r, w) = rigid_body::split(sol.last().1);
/// let (r_exact, w_exact) = rigid_body::symmetric_top(2.0, 3.0, &r0, &w0, 5.0);
/// assert!((r.matrix() - r_exact.matrix()).amax() < 1e-9 && (w - w_exact).amax() < 1e-9);
/// ```
#[derive(Debug, Clone)]
pub struct Cf4 {
    layout: Layout,
}

impl Cf4 {
    /// CF4 on states of this structure.
    ///
    /// ```
    /// use reckon::{methods::{Cf4, Method}, lie::Layout};
    /// let m = Cf4::new(Layout::left().se3(0));
    /// assert_eq!(<Cf4 as Method<nalgebra::U12>>::order(&m), 4);
    /// ```
    pub fn new(layout: Layout) -> Self {
        Cf4 { layout }
    }
}

impl<D: Dim> Method<D> for Cf4
where
    DefaultAllocator: Allocator<D>,
{
    type Stepper = Cf4Stepper<D>;
    fn name(&self) -> &'static str {
        "cf4"
    }
    fn order(&self) -> u32 {
        4
    }
    fn error_order(&self) -> Option<u32> {
        None
    }
    fn never_retries(&self) -> bool {
        true
    }
    fn stepper<S: System<D>>(self, _f: &mut Eval<'_, D, S>, _t0: f64, x0: &OVector<f64, D>) -> Result<Self::Stepper> {
        self.layout.check(x0.as_slice())?;
        Ok(Cf4Stepper {
            layout: self.layout,
            f0: x0.clone(),
            fy: x0.clone(),
            k: std::array::from_fn(|_| x0.clone()),
            v: x0.clone(),
            y2: x0.clone(),
            y: x0.clone(),
        })
    }
}

/// [`Cf4`]'s run: the layout, `f(t₀, x₀)` (the dense output's first slope), the
/// stages `F₁…F₄` (packed tangents) and work vectors.
#[derive(Debug, Clone)]
pub struct Cf4Stepper<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    layout: Layout,
    f0: OVector<f64, D>,
    fy: OVector<f64, D>,
    k: [OVector<f64, D>; 4],
    v: OVector<f64, D>,
    y2: OVector<f64, D>,
    y: OVector<f64, D>,
}

impl<D: Dim> Cf4Stepper<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// `v ← Σ wⱼ Fⱼ`.
    fn combine(&mut self, w: [f64; 4]) {
        for i in 0..self.v.len() {
            self.v[i] = (0..4).map(|j| w[j] * self.k[j][i]).sum();
        }
    }
}

impl<D: Dim> Stepper<D> for Cf4Stepper<D>
where
    DefaultAllocator: Allocator<D>,
{
    fn step<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, s: Step<'_, D>) -> Result<Outcome> {
        let Step { t, x, h, x_new, .. } = s;
        let Cf4Stepper {
            layout: l,
            f0,
            fy,
            k,
            v,
            y2,
            y,
        } = self;
        let (xs, half) = (x.as_slice(), t + 0.5 * h);
        // F₁ at Y₀
        f.rhs(t, x, f0)?;
        l.algebra(xs, f0.as_slice(), k[0].as_mut_slice());
        k[0] *= h;
        // Y₂ = Y₀·Exp(F₁/2)
        v.copy_from(&k[0]);
        *v *= 0.5;
        l.exp_act(v.as_slice(), xs, y2.as_mut_slice());
        f.rhs(half, y2, fy)?;
        l.algebra(y2.as_slice(), fy.as_slice(), k[1].as_mut_slice());
        k[1] *= h;
        // Y₃ = Y₀·Exp(F₂/2)
        v.copy_from(&k[1]);
        *v *= 0.5;
        l.exp_act(v.as_slice(), xs, y.as_mut_slice());
        f.rhs(half, y, fy)?;
        l.algebra(y.as_slice(), fy.as_slice(), k[2].as_mut_slice());
        k[2] *= h;
        // Y₄ = Y₂·Exp(F₃ − F₁/2)
        self.combine([-0.5, 0.0, 1.0, 0.0]);
        let Cf4Stepper {
            layout: l,
            fy,
            k,
            v,
            y2,
            y,
            ..
        } = self;
        l.exp_act(v.as_slice(), y2.as_slice(), y.as_mut_slice());
        f.rhs(t + h, y, fy)?;
        l.algebra(y.as_slice(), fy.as_slice(), k[3].as_mut_slice());
        k[3] *= h;
        // Y_½ = Y₀·Exp((3F₁ + 2F₂ + 2F₃ − F₄)/12), then Y₁ = Y_½·Exp((−F₁ + 2F₂ + 2F₃ + 3F₄)/12)
        let q = 1.0 / 12.0;
        self.combine([3.0 * q, 2.0 * q, 2.0 * q, -q]);
        self.layout.exp_act(self.v.as_slice(), xs, self.y.as_mut_slice());
        self.combine([-q, 2.0 * q, 2.0 * q, 3.0 * q]);
        self.layout
            .exp_act(self.v.as_slice(), self.y.as_slice(), x_new.as_mut_slice());
        self.layout.project(x_new.as_mut_slice());
        Ok(Outcome::Done { err: 0.0 })
    }
    fn dense_len(&self) -> usize {
        4
    }
    /// The cubic Hermite interpolant through both ends and both slopes (one more `f`
    /// call, at the end), in ambient coordinates.
    fn dense<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t: f64,
        h: f64,
        x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
        c: &mut [OVector<f64, D>],
    ) -> Result<()> {
        c[1].copy_from(&self.f0);
        f.rhs(t + h, x_new, &mut c[3])?;
        super::dense::cubic_hermite(h, x, x_new, c);
        Ok(())
    }
}

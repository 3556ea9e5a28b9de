//! Lie–Euler: the explicit Euler method on a Lie group (Iserles, Munthe-Kaas, Nørsett
//! and Zanna, "Lie-group methods", Acta Numerica 2000, §4).

use super::{Method, Outcome, Step, Stepper};
use crate::error::Result;
use crate::lie::Layout;
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Lie–Euler: `Y₁ = Y₀·Exp(h·ξ(t₀, Y₀))` on each group block of the [`Layout`]
/// (`Exp(h·ξ)·Y₀` for the left form), `x₁ = x₀ + h·f(t₀, x₀)` on the vector
/// components; order 1, fixed step only (no error estimate). A constant twist is
/// integrated exactly, in one exponential. The rotations of each result get one polar
/// step ([`Layout::project`]) against rounding.
///
/// ```
/// use reckon::{methods::LieEuler, vehicles::rigid_body, Options, Problem, StepSize};
/// let x0 = rigid_body::state(&reckon::lie::So3::identity(), &nalgebra::vector![0.0, 0.0, 1.0]);
/// let f = rigid_body::model([1.0, 1.0, 2.0]);
/// let sol = Problem::new(&f, x0, (0.0, 1.0))
///     .solve(LieEuler::new(rigid_body::layout()), &Options::default().step(StepSize::Fixed(0.5)))
///     .unwrap();
/// // a spin about the symmetry axis: R(1) = Exp(0, 0, 1) exactly
/// let (r, _) = rigid_body::split(sol.last().1);
/// assert!((r.log() - nalgebra::vector![0.0, 0.0, 1.0]).norm() < 1e-15);
/// ```
#[derive(Debug, Clone)]
pub struct LieEuler {
    layout: Layout,
}

impl LieEuler {
    /// Lie–Euler on states of this structure.
    ///
    /// ```
    /// use reckon::{methods::{LieEuler, Method}, lie::Layout};
    /// let m = LieEuler::new(Layout::right().so3(0));
    /// assert_eq!(<LieEuler as Method<nalgebra::U12>>::order(&m), 1);
    /// ```
    pub fn new(layout: Layout) -> Self {
        LieEuler { layout }
    }
}

impl<D: Dim> Method<D> for LieEuler
where
    DefaultAllocator: Allocator<D>,
{
    type Stepper = LieEulerStepper<D>;
    fn name(&self) -> &'static str {
        "lie_euler"
    }
    fn order(&self) -> u32 {
        1
    }
    fn error_order(&self) -> Option<u32> {
        None
    }
    fn never_retries(&self) -> bool {
        true
    }
    fn stepper<S: System<D>>(self, _f: &mut Eval<'_, D, S>, _t0: f64, x0: &OVector<f64, D>) -> Result<Self::Stepper> {
        self.layout.check(x0.as_slice())?;
        Ok(LieEulerStepper {
            layout: self.layout,
            f0: x0.clone(),
            xi: x0.clone(),
        })
    }
}

/// [`LieEuler`]'s run: the layout, `f(t₀, x₀)` of the last step (the dense output's
/// first slope) and the tangent.
#[derive(Debug, Clone)]
pub struct LieEulerStepper<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    layout: Layout,
    f0: OVector<f64, D>,
    xi: OVector<f64, D>,
}

impl<D: Dim> Stepper<D> for LieEulerStepper<D>
where
    DefaultAllocator: Allocator<D>,
{
    fn step<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, s: Step<'_, D>) -> Result<Outcome> {
        let Step { t, x, h, x_new, .. } = s;
        let l = &self.layout;
        f.rhs(t, x, &mut self.f0)?;
        l.algebra(x.as_slice(), self.f0.as_slice(), self.xi.as_mut_slice());
        self.xi *= h;
        l.exp_act(self.xi.as_slice(), x.as_slice(), x_new.as_mut_slice());
        l.project(x_new.as_mut_slice());
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

//! [`Lhs`]: an `f64` literal on the left of `+ - * /` in a [`model!`](crate::model) body.
//!
//! `2.0 * x[0]` cannot compile when `x[0]` is a num-dual number: `f64 × dual` could
//! only be implemented by num-dual (Rust's orphan rule). `model!` rewrites such a
//! literal into `Lhs(2.0)` (a call, so precedence is unchanged) and the operators
//! below give the value Rust gives for `f64` (bit for bit) and, for the dual numbers,
//! the same real part and the derivative of the written expression:
//!
//! - `l * r` and `l + r` are `r * l` and `r + l` (IEEE multiplication and addition are
//!   commutative; num-dual scales every derivative by `l`, or leaves them as they are);
//! - `l - r` is `R::from(l) - r`: real part `l − re`, derivative `0 − ε = −ε`;
//! - `l / r` is `R::from(l) / r` (num-dual's quotient rule, derivative
//!   `−l·ε/re²`) with the real part set to `l / re`, Rust's `f64` quotient
//!   (num-dual's own is `l · (1/re)`, which can differ in the last bit).
//!
//! The impls are concrete (`f64`, `Dual64`, `DualVec64<D>`, nalgebra matrices):
//! one generic impl over "anything `f64` can multiply" would overlap the others
//! under coherence.

use nalgebra::allocator::Allocator;
use nalgebra::storage::Storage;
use nalgebra::{DefaultAllocator, Dim, Matrix, OMatrix, Scalar};
use num_dual::{Dual64, DualVec64};
use std::ops::{Add, Div, Mul, Sub};

/// An `f64` literal that was the left operand of `+ - * /` in a `model!` body.
#[doc(hidden)]
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct Lhs(pub f64);

impl Mul<f64> for Lhs {
    type Output = f64;
    #[inline(always)]
    fn mul(self, r: f64) -> f64 {
        r * self.0
    }
}

impl Add<f64> for Lhs {
    type Output = f64;
    #[inline(always)]
    fn add(self, r: f64) -> f64 {
        r + self.0
    }
}

impl Sub<f64> for Lhs {
    type Output = f64;
    #[inline(always)]
    fn sub(self, r: f64) -> f64 {
        self.0 - r
    }
}

impl Div<f64> for Lhs {
    type Output = f64;
    #[inline(always)]
    fn div(self, r: f64) -> f64 {
        self.0 / r
    }
}

impl Mul<Dual64> for Lhs {
    type Output = Dual64;
    #[inline]
    fn mul(self, r: Dual64) -> Dual64 {
        r * self.0
    }
}

impl Add<Dual64> for Lhs {
    type Output = Dual64;
    #[inline]
    fn add(self, r: Dual64) -> Dual64 {
        r + self.0
    }
}

impl Sub<Dual64> for Lhs {
    type Output = Dual64;
    #[inline]
    fn sub(self, r: Dual64) -> Dual64 {
        Dual64::from(self.0) - r
    }
}

impl Div<Dual64> for Lhs {
    type Output = Dual64;
    #[inline]
    fn div(self, r: Dual64) -> Dual64 {
        let re = self.0 / r.re;
        let mut q = Dual64::from(self.0) / r;
        q.re = re;
        q
    }
}

impl<D: Dim> Mul<DualVec64<D>> for Lhs
where
    DefaultAllocator: Allocator<D>,
{
    type Output = DualVec64<D>;
    #[inline]
    fn mul(self, r: DualVec64<D>) -> DualVec64<D> {
        r * self.0
    }
}

impl<D: Dim> Add<DualVec64<D>> for Lhs
where
    DefaultAllocator: Allocator<D>,
{
    type Output = DualVec64<D>;
    #[inline]
    fn add(self, r: DualVec64<D>) -> DualVec64<D> {
        r + self.0
    }
}

impl<D: Dim> Sub<DualVec64<D>> for Lhs
where
    DefaultAllocator: Allocator<D>,
{
    type Output = DualVec64<D>;
    #[inline]
    fn sub(self, r: DualVec64<D>) -> DualVec64<D> {
        DualVec64::from(self.0) - r
    }
}

impl<D: Dim> Div<DualVec64<D>> for Lhs
where
    DefaultAllocator: Allocator<D>,
{
    type Output = DualVec64<D>;
    #[inline]
    fn div(self, r: DualVec64<D>) -> DualVec64<D> {
        let re = self.0 / r.re;
        let mut q = DualVec64::from(self.0) / r;
        q.re = re;
        q
    }
}

/// The tracing scalar: `l ∘ r` records the literal as a constant node, in the order written.
macro_rules! lhs_sym {
    ($($tr:ident $f:ident),*) => {$(
        impl $tr<crate::symbolic::Sym> for Lhs {
            type Output = crate::symbolic::Sym;
            #[inline]
            fn $f(self, r: crate::symbolic::Sym) -> crate::symbolic::Sym {
                crate::symbolic::Sym::from(self.0).$f(r)
            }
        }
    )*};
}
lhs_sym!(Mul mul, Add add, Sub sub, Div div);

/// `l ∘ &r` as `l ∘ r.clone()`, as for `f64 ∘ &f64`.
macro_rules! by_ref {
    ($op:ident $f:ident, [$($g:tt)*] $ty:ty, [$($w:tt)*]) => {
        impl<'a, $($g)*> $op<&'a $ty> for Lhs
        where
            $($w)*
        {
            type Output = $ty;
            #[inline(always)]
            fn $f(self, r: &'a $ty) -> $ty {
                self.$f(r.clone())
            }
        }
    };
    ($g:tt $ty:ty, $w:tt) => {
        by_ref!(Mul mul, $g $ty, $w);
        by_ref!(Add add, $g $ty, $w);
        by_ref!(Sub sub, $g $ty, $w);
        by_ref!(Div div, $g $ty, $w);
    };
}
by_ref!([] f64, []);
by_ref!([] Dual64, []);
by_ref!([] crate::symbolic::Sym, []);
by_ref!([D: Dim] DualVec64<D>, [DefaultAllocator: Allocator<D>]);

/// Scalar times matrix, as nalgebra's `f64 * m`: every entry `e * l`.
impl<T, R: Dim, C: Dim, S: Storage<T, R, C>> Mul<Matrix<T, R, C, S>> for Lhs
where
    T: Scalar + Mul<f64, Output = T>,
    DefaultAllocator: Allocator<R, C>,
{
    type Output = OMatrix<T, R, C>;
    #[inline]
    fn mul(self, m: Matrix<T, R, C, S>) -> OMatrix<T, R, C> {
        m.map(|e| e * self.0)
    }
}

impl<'a, T, R: Dim, C: Dim, S: Storage<T, R, C>> Mul<&'a Matrix<T, R, C, S>> for Lhs
where
    T: Scalar + Mul<f64, Output = T>,
    DefaultAllocator: Allocator<R, C>,
{
    type Output = OMatrix<T, R, C>;
    #[inline]
    fn mul(self, m: &'a Matrix<T, R, C, S>) -> OMatrix<T, R, C> {
        m.map(|e| e * self.0)
    }
}

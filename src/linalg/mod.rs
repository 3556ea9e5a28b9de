//! Linear algebra, below the model: LU factorisation chosen by the state dimension
//! (nalgebra's stack-allocated LU for fixed sizes `Const<N>`, faer's partial-pivoting LU
//! for `Dyn`), faer's sparse LU for a fixed [`Pattern`](crate::jacobian::Pattern)
//! ([`SparseLu`]) and a banded LU for patterns in a narrow band ([`BandLu`]), the matrix exponential ([`expm`]) and restarted Arnoldi for the
//! spectrum of a large sparse matrix ([`arnoldi`]). The Newton iteration matrix
//! `I − h·J` that the implicit methods share is built on these in `methods`.

use nalgebra::{Const, DMatrix, DVector, Dyn, OMatrix, OVector, SMatrix, SVector};

pub mod arnoldi;
pub mod expm;

mod band_lu;
mod sparse_lu;

pub use band_lu::{Band, BandLu};
pub use sparse_lu::SparseLu;

/// Whether some `v` is NaN or ±∞ (every exponent bit set). Up to 8 values a test per
/// value that stops at the first bad one (measured on Robertson's 3 states with an
/// opaque `f`: the fold cost 7 % of the whole BDF solve); past them an OR over all of
/// them without an early exit, which the compiler vectorises.
#[inline]
pub(crate) fn any_non_finite(v: &[f64]) -> bool {
    const EXPONENT: u64 = 0x7ff0_0000_0000_0000;
    if v.len() <= 8 {
        return v.iter().any(|a| !a.is_finite());
    }
    v.iter()
        .fold(false, |any, a| any | (a.to_bits() & EXPONENT == EXPONENT))
}

/// A factorisation of a square matrix that can solve `M·y = b` in place.
#[doc(hidden)]
pub trait Lu<D: nalgebra::Dim>: Sized
where
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D> + nalgebra::allocator::Allocator<D, D>,
{
    /// Factor `m`; `None` when it is singular, has non-finite pivots or is not square.
    fn factor(m: &OMatrix<f64, D, D>) -> Option<Self>;
    /// `b ← M⁻¹·b`; [`Error::InvalidInput`](crate::Error::InvalidInput) (and `b`
    /// untouched) when `b` does not have as many entries as `M` has rows.
    fn solve_in_place(&self, b: &mut OVector<f64, D>) -> crate::Result<()>;
}

/// Dimensions that know their LU backend.
pub trait LuDim: nalgebra::Dim
where
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<Self> + nalgebra::allocator::Allocator<Self, Self>,
{
    /// The factorisation used for this dimension.
    type Lu: Lu<Self>;
}

/// nalgebra's LU with partial pivoting, on the stack (no allocation).
#[doc(hidden)]
pub struct FixedLu<const N: usize>(nalgebra::linalg::LU<f64, Const<N>, Const<N>>)
where
    Const<N>: nalgebra::DimMin<Const<N>, Output = Const<N>>;

/// nalgebra's LU needs `Const<N>: DimMin`, which exists for concrete sizes only,
/// so the fixed-size backend is instantiated for states of 1 to 32 components
/// (larger systems use `DVector` and faer).
macro_rules! fixed_lu {
    ($($n:literal)*) => {$(
        impl Lu<Const<$n>> for FixedLu<$n> {
            fn factor(m: &SMatrix<f64, $n, $n>) -> Option<Self> {
                let lu = nalgebra::linalg::LU::new(*m);
                let u = lu.u();
                let ok = (0..$n).all(|i| u[(i, i)] != 0.0 && u[(i, i)].is_finite());
                ok.then_some(FixedLu(lu))
            }
            fn solve_in_place(&self, b: &mut SVector<f64, $n>) -> crate::Result<()> {
                self.0.solve_mut(b);
                Ok(())
            }
        }
        impl LuDim for Const<$n> {
            type Lu = FixedLu<$n>;
        }
    )*};
}
fixed_lu!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32);

/// faer's LU with partial pivoting, for large dynamic systems.
///
/// ```
/// use reckon::linalg::{DynLu, Lu};
/// use nalgebra::{dmatrix, dvector};
/// let lu = DynLu::factor(&dmatrix![2.0, 0.0; 0.0, 4.0]).unwrap();
/// let mut b = dvector![2.0, 8.0];
/// lu.solve_in_place(&mut b).unwrap();
/// assert_eq!(b, dvector![1.0, 2.0]);
/// let e = lu.solve_in_place(&mut dvector![1.0, 2.0, 3.0]).unwrap_err();
/// assert_eq!(e.to_string(), "invalid rhs: 3 entries for a 2 × 2 matrix");
/// assert!(DynLu::factor(&dmatrix![1.0, 2.0, 3.0]).is_none()); // not square
/// ```
#[doc(hidden)]
pub struct DynLu(faer::linalg::solvers::PartialPivLu<f64>);

impl Lu<Dyn> for DynLu {
    fn factor(m: &DMatrix<f64>) -> Option<Self> {
        let (r, c) = m.shape();
        if r != c {
            return None;
        }
        let view = faer::MatRef::from_column_major_slice(m.as_slice(), r, c);
        let lu = view.partial_piv_lu();
        let u = lu.U();
        let ok = (0..r.min(c)).all(|i| {
            let d = u[(i, i)];
            d != 0.0 && d.is_finite()
        });
        ok.then_some(DynLu(lu))
    }
    fn solve_in_place(&self, b: &mut DVector<f64>) -> crate::Result<()> {
        use faer::linalg::solvers::Solve;
        let n = b.len();
        let rows = self.0.L().nrows();
        if n != rows {
            return Err(crate::Error::invalid(
                "rhs",
                format!("{n} entries for a {rows} × {rows} matrix"),
            ));
        }
        let rhs = faer::MatMut::from_column_major_slice_mut(b.as_mut_slice(), n, 1);
        self.0.solve_in_place(rhs);
        Ok(())
    }
}

impl LuDim for Dyn {
    type Lu = DynLu;
}

#[cfg(test)]
mod tests {
    use super::any_non_finite;

    #[test]
    fn any_non_finite_finds_every_bad_value_at_every_place() {
        let finite = [0.0, -0.0, 1.0, f64::MAX, f64::MIN, f64::MIN_POSITIVE, 5e-324, -5e-324];
        for n in 0..40 {
            let v: Vec<f64> = (0..n).map(|i| finite[i % finite.len()]).collect();
            assert!(!any_non_finite(&v), "{n} finite values");
            for bad in [f64::NAN, -f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                for at in 0..n {
                    let mut w = v.clone();
                    w[at] = bad;
                    assert!(any_non_finite(&w), "{bad} at {at} of {n}");
                }
            }
        }
    }
}

//! [`Sym`]: the tracing scalar. A `Sym` is a node id in a thread-local expression graph;
//! every arithmetic operation or function call on it adds (or finds) a node instead of
//! computing a number. It implements num-dual's `DualNum<f64>`, so a `model!` body and
//! the generic helper functions it calls run on it unchanged.
//!
//! A body that asks a traced value for something a graph cannot answer (a comparison, a
//! sign test, its numeric value) records a fault: the trace is then refused with
//! [`Error::Untraceable`](crate::Error::Untraceable) instead of silently recording one branch.

use super::graph::{Func, Graph, Node};
use num_dual::{DualNum, DualStruct, Mappable};
use std::cell::RefCell;
use std::cmp::Ordering;
use std::fmt;
use std::iter::{Product, Sum};
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Rem, RemAssign, Sub, SubAssign};

/// A traced scalar: a handle to a node of the expression graph being recorded.
///
/// Only meaningful inside [`trace`](super::trace) (or a model's own trace); `Copy`, so a
/// body may index a slice of them (`u[0]`) like `f64`s.
#[derive(Clone, Copy)]
pub struct Sym(pub(crate) u32);

/// What made a body untraceable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fault {
    /// It compared a traced value (`<`, `==`, `is_positive`…): its control flow depends on it.
    Compare(&'static str),
    /// It read a traced value's number (`re()`).
    Value,
    /// A NaN or ±∞ entered the graph as a constant: the body computed with an `f64` the
    /// trace gives as ±∞ (a time `t` written without `: S`), or with a non-finite number.
    PlainValue,
}

#[derive(Default)]
struct Tape {
    g: Graph,
    active: bool,
    fault: Option<Fault>,
}

thread_local! {
    static TAPE: RefCell<Tape> = RefCell::new(Tape::default());
    static PLAIN_TIME: std::cell::Cell<f64> = const { std::cell::Cell::new(f64::NAN) };
}

/// The value a traced body sees for a time written as a plain `t` (an `f64`) or `_`: `+∞`.
/// A body that names a plain `t` is refused before it runs (`model!` checks the body's
/// tokens), so this is only a guard: a hidden use that computes with it records a
/// non-finite constant and is refused.
#[doc(hidden)]
pub fn plain_time() -> f64 {
    PLAIN_TIME.with(|c| c.get())
}

/// Set [`plain_time`] for the next recording.
pub(crate) fn set_plain_time(v: f64) {
    PLAIN_TIME.with(|c| c.set(v));
}

fn with<R>(f: impl FnOnce(&mut Graph) -> R) -> R {
    TAPE.with(|t| f(&mut t.borrow_mut().g))
}

fn fault(kind: Fault) {
    TAPE.with(|t| {
        let mut t = t.borrow_mut();
        t.fault.get_or_insert(kind);
    });
}

/// Resets the tape when a recording ends, also by panic.
struct Recording;

impl Drop for Recording {
    fn drop(&mut self) {
        TAPE.with(|t| {
            let mut t = t.borrow_mut();
            t.active = false;
        });
    }
}

/// Run `body` on a fresh tape whose first nodes are `leaves` (interned in order) and
/// return the graph with `body`'s result; `Err` with the first fault, or `Err(None)` when
/// a recording is already running on this thread (a body that traces inside a trace).
/// `capacity`: the number of nodes expected (room made up front).
pub(crate) fn record<R>(
    leaves: &[Node],
    capacity: usize,
    body: impl FnOnce(&[Sym]) -> R,
) -> Result<(Graph, R), Option<Fault>> {
    let started = TAPE.with(|t| {
        let mut t = t.borrow_mut();
        if t.active {
            return false;
        }
        *t = Tape {
            g: Graph::with_capacity(capacity),
            active: true,
            fault: None,
        };
        true
    });
    if !started {
        return Err(None);
    }
    let guard = Recording;
    let syms: Vec<Sym> = leaves.iter().map(|&n| Sym(with(|g| g.intern(n)))).collect();
    let r = body(&syms);
    drop(guard);
    TAPE.with(|t| {
        let mut t = t.borrow_mut();
        let g = std::mem::take(&mut t.g);
        match t.fault.take() {
            Some(f) => Err(Some(f)),
            None => Ok((g, r)),
        }
    })
}

impl Sym {
    /// The node id of this value in its graph.
    pub fn id(self) -> u32 {
        self.0
    }

    fn constant(self) -> Option<f64> {
        with(|g| g.constant(self.0))
    }

    fn un(self, f: Func) -> Sym {
        Sym(with(|g| g.func(f, self.0)))
    }

    fn lift(v: f64) -> Sym {
        // the trace gives a plain-f64 time as ±∞: a constant computed from it is not finite
        if !v.is_finite() {
            fault(Fault::PlainValue);
        }
        Sym(with(|g| g.num(v)))
    }
}

impl From<f64> for Sym {
    fn from(v: f64) -> Sym {
        Sym::lift(v)
    }
}

impl fmt::Debug for Sym {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Sym(#{})", self.0)
    }
}

impl fmt::Display for Sym {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = with(|g| super::print::text(g, self.0, &super::Names::default()));
        f.write_str(&s)
    }
}

impl PartialEq for Sym {
    fn eq(&self, other: &Sym) -> bool {
        if self.0 == other.0 {
            return true;
        }
        match (self.constant(), other.constant()) {
            (Some(a), Some(b)) => a == b,
            _ => {
                fault(Fault::Compare("=="));
                false
            }
        }
    }
}

impl PartialOrd for Sym {
    fn partial_cmp(&self, other: &Sym) -> Option<Ordering> {
        match (self.constant(), other.constant()) {
            (Some(a), Some(b)) => a.partial_cmp(&b),
            _ => {
                fault(Fault::Compare("a comparison (<, >, <=, >=)"));
                Some(Ordering::Equal)
            }
        }
    }
}

impl PartialEq<f64> for Sym {
    fn eq(&self, other: &f64) -> bool {
        match self.constant() {
            Some(a) => a == *other,
            None => {
                fault(Fault::Compare("=="));
                false
            }
        }
    }
}

impl PartialOrd<f64> for Sym {
    fn partial_cmp(&self, other: &f64) -> Option<Ordering> {
        match self.constant() {
            Some(a) => a.partial_cmp(other),
            None => {
                fault(Fault::Compare("a comparison (<, >, <=, >=)"));
                Some(Ordering::Equal)
            }
        }
    }
}

macro_rules! binop {
    ($tr:ident $f:ident $atr:ident $af:ident $g:ident) => {
        impl $tr for Sym {
            type Output = Sym;
            #[inline]
            fn $f(self, r: Sym) -> Sym {
                Sym(with(|g| g.$g(self.0, r.0)))
            }
        }
        impl<'a> $tr<&'a Sym> for Sym {
            type Output = Sym;
            #[inline]
            fn $f(self, r: &'a Sym) -> Sym {
                self.$f(*r)
            }
        }
        impl<'a> $tr<Sym> for &'a Sym {
            type Output = Sym;
            #[inline]
            fn $f(self, r: Sym) -> Sym {
                (*self).$f(r)
            }
        }
        impl<'a, 'b> $tr<&'b Sym> for &'a Sym {
            type Output = Sym;
            #[inline]
            fn $f(self, r: &'b Sym) -> Sym {
                (*self).$f(*r)
            }
        }
        impl $tr<f64> for Sym {
            type Output = Sym;
            #[inline]
            fn $f(self, r: f64) -> Sym {
                self.$f(Sym::lift(r))
            }
        }
        impl $tr<Sym> for f64 {
            type Output = Sym;
            #[inline]
            fn $f(self, r: Sym) -> Sym {
                Sym::lift(self).$f(r)
            }
        }
        impl $atr for Sym {
            #[inline]
            fn $af(&mut self, r: Sym) {
                *self = (*self).$f(r);
            }
        }
        impl<'a> $atr<&'a Sym> for Sym {
            #[inline]
            fn $af(&mut self, r: &'a Sym) {
                *self = (*self).$f(*r);
            }
        }
        impl $atr<f64> for Sym {
            #[inline]
            fn $af(&mut self, r: f64) {
                *self = (*self).$f(r);
            }
        }
    };
}
binop!(Add add AddAssign add_assign add);
binop!(Sub sub SubAssign sub_assign sub);
binop!(Mul mul MulAssign mul_assign mul);
binop!(Div div DivAssign div_assign div);
binop!(Rem rem RemAssign rem_assign rem);

impl Neg for Sym {
    type Output = Sym;
    fn neg(self) -> Sym {
        Sym(with(|g| g.neg(self.0)))
    }
}

impl Neg for &Sym {
    type Output = Sym;
    fn neg(self) -> Sym {
        -*self
    }
}

impl Sum for Sym {
    fn sum<I: Iterator<Item = Sym>>(iter: I) -> Sym {
        iter.fold(Sym::lift(0.0), |a, b| a + b)
    }
}

impl<'a> Sum<&'a Sym> for Sym {
    fn sum<I: Iterator<Item = &'a Sym>>(iter: I) -> Sym {
        iter.fold(Sym::lift(0.0), |a, b| a + *b)
    }
}

impl Product for Sym {
    fn product<I: Iterator<Item = Sym>>(iter: I) -> Sym {
        iter.fold(Sym::lift(1.0), |a, b| a * b)
    }
}

impl<'a> Product<&'a Sym> for Sym {
    fn product<I: Iterator<Item = &'a Sym>>(iter: I) -> Sym {
        iter.fold(Sym::lift(1.0), |a, b| a * *b)
    }
}

impl num_traits::Zero for Sym {
    fn zero() -> Sym {
        Sym::lift(0.0)
    }
    /// `true` only for the constant 0 (structural: a traced value is "not known to be 0").
    fn is_zero(&self) -> bool {
        self.constant() == Some(0.0)
    }
}

impl num_traits::One for Sym {
    fn one() -> Sym {
        Sym::lift(1.0)
    }
}

impl num_traits::Num for Sym {
    type FromStrRadixErr = <f64 as num_traits::Num>::FromStrRadixErr;
    fn from_str_radix(s: &str, radix: u32) -> Result<Sym, Self::FromStrRadixErr> {
        f64::from_str_radix(s, radix).map(Sym::lift)
    }
}

impl num_traits::Signed for Sym {
    fn abs(&self) -> Sym {
        self.un(Func::Abs)
    }
    /// `max(a − b, 0) = (d + |d|)/2` with `d = a − b`: no branch.
    fn abs_sub(&self, other: &Sym) -> Sym {
        let d = *self - *other;
        (d + d.un(Func::Abs)) * 0.5
    }
    fn signum(&self) -> Sym {
        self.un(Func::Sign)
    }
    fn is_positive(&self) -> bool {
        match self.constant() {
            Some(a) => a > 0.0,
            None => {
                fault(Fault::Compare("is_positive"));
                false
            }
        }
    }
    fn is_negative(&self) -> bool {
        match self.constant() {
            Some(a) => a < 0.0,
            None => {
                fault(Fault::Compare("is_negative"));
                false
            }
        }
    }
}

impl num_traits::Inv for Sym {
    type Output = Sym;
    fn inv(self) -> Sym {
        Sym::lift(1.0) / self
    }
}

impl num_traits::FromPrimitive for Sym {
    fn from_i64(n: i64) -> Option<Sym> {
        Some(Sym::lift(n as f64))
    }
    fn from_u64(n: u64) -> Option<Sym> {
        Some(Sym::lift(n as f64))
    }
    fn from_f64(n: f64) -> Option<Sym> {
        Some(Sym::lift(n))
    }
}

impl DualStruct for Sym {
    type Real = f64;
    type Inner = f64;
    /// The number of a constant; for a traced value a fault (its number is not known
    /// while tracing) and NaN.
    fn re(&self) -> f64 {
        match self.constant() {
            Some(a) => a,
            None => {
                fault(Fault::Value);
                f64::NAN
            }
        }
    }
    fn from_inner(inner: &f64) -> Sym {
        Sym::lift(*inner)
    }
}

impl Mappable<Sym> for Sym {
    type Output<O> = O;
    fn map_dual<M: Fn(Sym) -> O, O>(self, f: M) -> O {
        f(self)
    }
}

impl DualNum for Sym {
    type Primitive = f64;
    const NDERIV: usize = 0;
    type InnerDual = f64;
    fn from_re(re: f64) -> Sym {
        Sym::lift(re)
    }
    fn scale(self, factor: &f64) -> Sym {
        self * *factor
    }
    fn recip(&self) -> Sym {
        Sym::lift(1.0) / *self
    }
    fn powi(&self, n: i32) -> Sym {
        Sym(with(|g| g.powi(self.0, n)))
    }
    fn powf(&self, n: f64) -> Sym {
        Sym(with(|g| g.powf(self.0, n)))
    }
    fn sqrt(&self) -> Sym {
        self.un(Func::Sqrt)
    }
    fn cbrt(&self) -> Sym {
        self.un(Func::Cbrt)
    }
    fn exp(&self) -> Sym {
        self.un(Func::Exp)
    }
    fn exp2(&self) -> Sym {
        (*self * std::f64::consts::LN_2).un(Func::Exp)
    }
    fn exp_m1(&self) -> Sym {
        self.un(Func::ExpM1)
    }
    fn ln(&self) -> Sym {
        self.un(Func::Ln)
    }
    fn log(&self, base: f64) -> Sym {
        self.un(Func::Ln) / base.ln()
    }
    fn log2(&self) -> Sym {
        self.un(Func::Ln) / std::f64::consts::LN_2
    }
    fn log10(&self) -> Sym {
        self.un(Func::Ln) / std::f64::consts::LN_10
    }
    fn ln_1p(&self) -> Sym {
        self.un(Func::Ln1p)
    }
    fn sin(&self) -> Sym {
        self.un(Func::Sin)
    }
    fn cos(&self) -> Sym {
        self.un(Func::Cos)
    }
    fn tan(&self) -> Sym {
        self.un(Func::Tan)
    }
    fn sin_cos(&self) -> (Sym, Sym) {
        (self.un(Func::Sin), self.un(Func::Cos))
    }
    fn asin(&self) -> Sym {
        self.un(Func::Asin)
    }
    fn acos(&self) -> Sym {
        self.un(Func::Acos)
    }
    fn atan(&self) -> Sym {
        self.un(Func::Atan)
    }
    fn atan2(&self, other: Sym) -> Sym {
        Sym(with(|g| g.atan2(self.0, other.0)))
    }
    fn sinh(&self) -> Sym {
        self.un(Func::Sinh)
    }
    fn cosh(&self) -> Sym {
        self.un(Func::Cosh)
    }
    fn tanh(&self) -> Sym {
        self.un(Func::Tanh)
    }
    fn asinh(&self) -> Sym {
        self.un(Func::Asinh)
    }
    fn acosh(&self) -> Sym {
        self.un(Func::Acosh)
    }
    fn atanh(&self) -> Sym {
        self.un(Func::Atanh)
    }
    /// `j₀(a) = sin a / a`
    fn sph_j0(&self) -> Sym {
        self.sin() / *self
    }
    /// `j₁(a) = (sin a − a cos a)/a²`
    fn sph_j1(&self) -> Sym {
        (self.sin() - *self * self.cos()) / self.powi(2)
    }
    /// `j₂(a) = ((3 − a²) sin a − 3a cos a)/a³`
    fn sph_j2(&self) -> Sym {
        let a2 = self.powi(2);
        ((Sym::lift(3.0) - a2) * self.sin() - *self * self.cos() * 3.0) / self.powi(3)
    }
    fn mul_add(&self, a: Sym, b: Sym) -> Sym {
        *self * a + b
    }
}

//! What [`Integrator::solve`](super::Integrator::solve) keeps of a run ([`Save`]): the
//! saver sees every accepted step (its end state, and for output times the step's dense
//! polynomial) and stores only what was asked for.

use crate::problem::options::Save;
use crate::problem::solution::horner;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// A step's start, size and dense coefficients.
pub(crate) type Segment<'c, D> = (f64, f64, &'c [OVector<f64, D>]);

/// Where a [`Saver`] puts the states it keeps: a `Vec` of states for a solve, or a store
/// that splits each state as it comes (the sensitivity schemes keep `x` and a flat `S`,
/// with nothing allocated per point).
pub(crate) trait Store<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Keep `x`.
    fn push(&mut self, x: &OVector<f64, D>);
    /// Keep the dense polynomial `Σ cⱼ θʲ` at `θ` (Horner).
    fn push_dense(&mut self, c: &[OVector<f64, D>], theta: f64) {
        self.push(&horner(c, theta));
    }
    /// Keep `x`, taking it.
    fn push_owned(&mut self, x: OVector<f64, D>) {
        self.push(&x);
    }
    /// Room for `n` more states.
    fn reserve(&mut self, n: usize);
}

impl<D: Dim> Store<D> for Vec<OVector<f64, D>>
where
    DefaultAllocator: Allocator<D>,
{
    #[inline(always)]
    fn push(&mut self, x: &OVector<f64, D>) {
        Vec::push(self, x.clone());
    }
    fn push_dense(&mut self, c: &[OVector<f64, D>], theta: f64) {
        Vec::push(self, horner(c, theta));
    }
    fn push_owned(&mut self, x: OVector<f64, D>) {
        Vec::push(self, x);
    }
    fn reserve(&mut self, n: usize) {
        Vec::reserve(self, n);
    }
}

pub(crate) struct Saver<D: Dim, St = Vec<OVector<f64, D>>>
where
    DefaultAllocator: Allocator<D>,
{
    mode: Mode,
    /// Output times (`Save::At`) and the index of the next one.
    at: Vec<f64>,
    next: usize,
    dir: f64,
    /// Accepted steps seen.
    seen: usize,
    /// The latest step end, kept for the end of the run when it was not stored.
    pending: Option<(f64, OVector<f64, D>)>,
    t: Vec<f64>,
    x: St,
}

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Steps,
    Every(usize),
    End,
    At,
}

impl<D: Dim> Saver<D>
where
    DefaultAllocator: Allocator<D>,
{
    pub(crate) fn new(save: &Save, dir: f64, t0: f64, x0: &OVector<f64, D>) -> Self {
        Self::with_store(save, dir, t0, x0, Vec::new())
    }
}

/// Every step written straight into the spare capacity of a [`Saver`]'s vectors: one
/// count and one room test for both (a `Vec::push` each tests its own capacity and
/// stores its own length), the lengths set when the room is refilled and when the
/// writer is dropped (on every way out, a panic included).
pub(crate) struct Slots<'s, D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    saver: &'s mut Saver<D>,
    /// The first free places of `saver.t` and `saver.x`, with room for `room` each.
    t: *mut f64,
    x: *mut OVector<f64, D>,
    room: usize,
    /// Places written since the lengths were last set.
    n: usize,
}

impl<'s, D: Dim> Slots<'s, D>
where
    DefaultAllocator: Allocator<D>,
{
    /// A writer at the end of every step kept by `saver` ([`Save::Steps`]).
    pub(crate) fn new(saver: &'s mut Saver<D>) -> Self {
        let mut s = Slots {
            saver,
            t: std::ptr::null_mut(),
            x: std::ptr::null_mut(),
            room: 0,
            n: 0,
        };
        s.aim();
        s
    }

    /// Point at the free places of both vectors (no step written since the lengths
    /// were set).
    fn aim(&mut self) {
        debug_assert_eq!(self.n, 0);
        let (t, x) = (&mut self.saver.t, &mut self.saver.x);
        self.room = (t.capacity() - t.len()).min(x.capacity() - x.len());
        self.t = t.spare_capacity_mut().as_mut_ptr().cast();
        self.x = x.spare_capacity_mut().as_mut_ptr().cast();
    }

    /// Set the lengths to take the places written.
    fn commit(&mut self) {
        let (t, x) = (&mut self.saver.t, &mut self.saver.x);
        // SAFETY: the first `n ≤ room` free places of both vectors were written (`keep`),
        // and nothing else touched the vectors since `aim` (they are borrowed here)
        unsafe {
            t.set_len(t.len() + self.n);
            x.set_len(x.len() + self.n);
        }
        self.n = 0;
    }

    /// The room is full: the lengths set, room reserved for as many again, and aimed.
    #[cold]
    #[inline(never)]
    fn refill(&mut self) {
        self.commit();
        let more = self.saver.t.len().max(64);
        self.saver.t.reserve(more);
        self.saver.x.reserve(more);
        self.aim();
    }

    /// Keep `(t, x)`.
    #[inline(always)]
    pub(crate) fn keep(&mut self, t: f64, x: &OVector<f64, D>) {
        if self.n >= self.room {
            self.refill();
        }
        // (every field read before the writes, which the compiler cannot tell apart
        // from them)
        let (n, tp, xp) = (self.n, self.t, self.x);
        // SAFETY: `n < room`: the place is inside both vectors' spare capacity, aimed at
        // since they last changed
        unsafe {
            tp.add(n).write(t);
            xp.add(n).write(x.clone());
        }
        self.n = n + 1;
    }
}

impl<D: Dim> Drop for Slots<'_, D>
where
    DefaultAllocator: Allocator<D>,
{
    fn drop(&mut self) {
        self.commit();
    }
}

/// Whether a run saving `save` needs each step's dense polynomial (output times).
pub(crate) fn needs_dense(save: &Save) -> bool {
    matches!(save, Save::At(_))
}

impl<D: Dim, St: Store<D>> Saver<D, St>
where
    DefaultAllocator: Allocator<D>,
{
    /// A saver keeping its states in `store`.
    pub(crate) fn with_store(save: &Save, dir: f64, t0: f64, x0: &OVector<f64, D>, store: St) -> Self {
        let (mode, at) = match save {
            Save::Steps => (Mode::Steps, Vec::new()),
            Save::Every(k) => (Mode::Every(*k), Vec::new()),
            Save::End => (Mode::End, Vec::new()),
            Save::At(ts) => (Mode::At, ts.clone()),
        };
        let mut s = Saver {
            mode,
            at,
            next: 0,
            dir,
            seen: 0,
            pending: None,
            t: Vec::new(),
            x: store,
        };
        if mode == Mode::At {
            while s.next < s.at.len() && s.at[s.next] == t0 {
                s.t.push(t0);
                s.x.push(x0);
                s.next += 1;
            }
        } else {
            s.t.push(t0);
            s.x.push(x0);
        }
        s
    }

    /// The first output time not saved yet ([`Save::At`]; `None` otherwise or when all
    /// are): a step that ends past it needs its dense polynomial.
    pub(super) fn next_time(&self) -> Option<f64> {
        match self.mode {
            Mode::At => self.at.get(self.next).copied(),
            _ => None,
        }
    }

    /// Whether only the end state is kept ([`Save::End`]).
    pub(super) fn end_only(&self) -> bool {
        self.mode == Mode::End
    }

    /// Whether every step is kept ([`Save::Steps`]).
    pub(super) fn every_step(&self) -> bool {
        self.mode == Mode::Steps
    }

    /// Store `(t, x)`.
    #[inline(always)]
    pub(super) fn push(&mut self, t: f64, x: &OVector<f64, D>) {
        self.t.push(t);
        self.x.push(x);
    }

    /// Room for `n` more kept steps when every step is kept (a run that knows a lower
    /// bound on its steps: one per control interval, say).
    pub(super) fn reserve(&mut self, n: usize) {
        if self.mode == Mode::Steps {
            self.t.reserve(n);
            self.x.reserve(n);
        }
    }

    /// An accepted step (or a landing on a stop) ending at `(t1, x1)`; `seg` is the step's
    /// `(t0, h)` and dense coefficients when the run keeps them.
    #[inline(always)]
    pub(crate) fn step(&mut self, t1: f64, x1: &OVector<f64, D>, seg: Option<Segment<'_, D>>) {
        match self.mode {
            Mode::Steps => self.push(t1, x1),
            Mode::Every(k) => {
                self.seen += 1;
                if self.seen.is_multiple_of(k) {
                    self.push(t1, x1);
                    self.pending = None;
                } else {
                    self.hold(t1, x1);
                }
            }
            Mode::End => self.hold(t1, x1),
            Mode::At => {
                self.hold(t1, x1);
                while self.next < self.at.len() && self.dir * (self.at[self.next] - t1) <= 0.0 {
                    let ta = self.at[self.next];
                    match seg {
                        Some((t0, h, c)) if ta != t1 && !c.is_empty() => self.x.push_dense(c, (ta - t0) / h),
                        _ => self.x.push(x1),
                    }
                    self.t.push(ta);
                    self.next += 1;
                }
            }
        }
    }

    /// A reset at the end of the step just passed to [`step`](Self::step): the state
    /// after it, at the same time, kept wherever every step (or every k-th) is, and held
    /// as the latest state otherwise.
    pub(crate) fn jump(&mut self, t: f64, x_after: &OVector<f64, D>) {
        match self.mode {
            Mode::Steps | Mode::Every(_) => {
                self.push(t, x_after);
                self.pending = None;
            }
            Mode::End | Mode::At => self.hold(t, x_after),
        }
    }

    /// Keep the latest step end for [`finish`](Self::finish), reusing the buffer.
    fn hold(&mut self, t1: f64, x1: &OVector<f64, D>) {
        match &mut self.pending {
            Some((t, x)) => {
                *t = t1;
                x.copy_from(x1);
            }
            None => self.pending = Some((t1, x1.clone())),
        }
    }

    /// The run ended: store the last step end if it was held back (for output times:
    /// only when the run stopped before the last of them, at a terminal event).
    pub(crate) fn finish(mut self) -> (Vec<f64>, St) {
        let keep = self.mode != Mode::At || self.next < self.at.len();
        if let Some((t, x)) = self.pending.take().filter(|_| keep) {
            self.t.push(t);
            self.x.push_owned(x);
        }
        (self.t, self.x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Vector2, vector};

    /// Slots write past the room first reserved (refilling), and the lengths are set on
    /// drop (every way out of a run): the kept steps are those a `push` per step keeps.
    #[test]
    fn slots_keep_what_pushes_keep_through_refills_and_drops() {
        let x0 = vector![1.0, -1.0];
        let mut a = Saver::<nalgebra::Const<2>>::new(&Save::Steps, 1.0, 0.0, &x0);
        let mut b = Saver::<nalgebra::Const<2>>::new(&Save::Steps, 1.0, 0.0, &x0);
        a.reserve(3);
        let step = |k: usize| (k as f64 * 0.25, Vector2::new(k as f64, -(k as f64).sqrt()));
        for round in 0..3 {
            // a writer per round: each drop sets the lengths, the next aims past them
            let mut s = Slots::new(&mut a);
            for k in round * 700..(round + 1) * 700 {
                let (t, x) = step(k);
                s.keep(t, &x);
                b.push(t, &x);
            }
        }
        let ((ta, xa), (tb, xb)) = (a.finish(), b.finish());
        assert_eq!(ta.len(), 2101);
        assert_eq!(ta, tb);
        assert_eq!(xa, xb);
        assert_eq!(ta[2100], 2099.0 * 0.25);
        assert_eq!(xa[2100], Vector2::new(2099.0, -(2099.0f64).sqrt()));
    }
}

//! Inputs held piecewise constant: `u(t) = u_k` for `t_k ≤ t < t_{k+1}`.

use crate::error::{Error, Result};

/// A control sequence `(t_k, u_k)`: `u_k` holds from `t_k` until `t_{k+1}`, the last
/// one from `t_last` on. Every `t_k` after the first is a breakpoint the integrator
/// lands on exactly, so no step ever straddles a jump in the inputs.
///
/// ```
/// use reckon::Controls;
/// let c = Controls::new(vec![0.0, 1.0, 2.5], vec![vec![1.0], vec![2.0], vec![0.0]]).unwrap();
/// assert_eq!(c.segment(0.5, 1.0), Some(0));
/// assert_eq!(c.segment(1.0, 1.0), Some(1)); // forward: the interval starting at 1
/// assert_eq!(c.segment(1.0, -1.0), Some(0)); // backward: the interval ending at 1
/// assert_eq!(c.values(1), Some(&[2.0][..]));
/// assert_eq!(c.values(3), None);
/// assert!(Controls::new(vec![1.0, 0.0], vec![vec![0.0], vec![0.0]]).is_err());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Controls {
    times: Vec<f64>,
    values: Vec<Vec<f64>>,
    width: usize,
}

impl Controls {
    /// Build from strictly increasing finite times and one equally long input row each.
    pub fn new(times: Vec<f64>, values: Vec<Vec<f64>>) -> Result<Self> {
        if times.is_empty() {
            return Err(Error::invalid("controls", "no control samples"));
        }
        if times.len() != values.len() {
            return Err(Error::invalid(
                "controls",
                format!("{} times but {} input rows", times.len(), values.len()),
            ));
        }
        let width = values[0].len();
        for (k, (t, u)) in times.iter().zip(&values).enumerate() {
            if !t.is_finite() || u.iter().any(|v| !v.is_finite()) {
                return Err(Error::invalid("controls", format!("sample {k} is not finite")));
            }
            if u.len() != width {
                return Err(Error::invalid(
                    "controls",
                    format!("sample {k} has {} inputs, sample 0 has {width}", u.len()),
                ));
            }
            if k > 0 && *t <= times[k - 1] {
                return Err(Error::invalid(
                    "controls",
                    format!("times must increase: t[{k}] = {t} after {}", times[k - 1]),
                ));
            }
        }
        Ok(Controls { times, values, width })
    }

    /// Number of inputs per sample.
    pub fn width(&self) -> usize {
        self.width
    }
    /// The sample times.
    pub fn times(&self) -> &[f64] {
        &self.times
    }
    /// Every row of inputs, in time order.
    pub(crate) fn rows(&self) -> &[Vec<f64>] {
        &self.values
    }
    /// Inputs of interval `k` (`None` past the last sample).
    pub fn values(&self, k: usize) -> Option<&[f64]> {
        self.values.get(k).map(|v| v.as_slice())
    }

    /// The interval in force at `t` when moving in direction `dir` (sign of `h`):
    /// forward the one with `t_k ≤ t < t_{k+1}`, backward `t_k < t ≤ t_{k+1}`.
    /// `None` before the first sample.
    pub fn segment(&self, t: f64, dir: f64) -> Option<usize> {
        self.segment_near(t, dir, None)
    }

    /// [`segment`](Self::segment), trying the intervals next to `hint` first (the one just
    /// left, when stepping through a long log) before a binary search: the same answer.
    ///
    /// ```
    /// use reckon::Controls;
    /// let c = Controls::new(vec![0.0, 1.0, 2.0], vec![vec![0.0], vec![1.0], vec![2.0]]).unwrap();
    /// for t in [-1.0, 0.0, 0.5, 1.0, 1.5, 2.0, 9.0] {
    ///     for dir in [1.0, -1.0] {
    ///         for hint in [None, Some(0), Some(1), Some(2)] {
    ///             assert_eq!(c.segment_near(t, dir, hint), c.segment(t, dir));
    ///         }
    ///     }
    /// }
    /// ```
    #[inline(always)]
    pub fn segment_near(&self, t: f64, dir: f64, hint: Option<usize>) -> Option<usize> {
        let n = self.times.len();
        // interval `c` is the one in force at `t`: the answer is unique, so checking a
        // candidate gives the binary search's result
        let holds = |c: usize| self.holds(c, t, dir);
        if let Some(h) = hint {
            // the next interval, then the hinted one
            let next = if dir >= 0.0 { h.checked_add(1) } else { h.checked_sub(1) };
            if let Some(c) = next
                && c < n
                && holds(c)
            {
                return Some(c);
            }
            if h < n && holds(h) {
                return Some(h);
            }
        }
        self.segment_search(t, dir)
    }

    /// Whether interval `c` (which must exist) is the one in force at `t` going in
    /// direction `dir`: `t_c ≤ t < t_{c+1}` forwards, `t_c < t ≤ t_{c+1}` backwards.
    #[inline(always)]
    fn holds(&self, c: usize, t: f64, dir: f64) -> bool {
        let n = self.times.len();
        if dir >= 0.0 {
            self.times[c] <= t && (c + 1 == n || t < self.times[c + 1])
        } else {
            self.times[c] < t && (c + 1 == n || t <= self.times[c + 1])
        }
    }

    /// The binary search behind [`segment_near`](Self::segment_near), out of line so
    /// that the check of the hinted intervals inlines into the driver's loop.
    #[inline(never)]
    fn segment_search(&self, t: f64, dir: f64) -> Option<usize> {
        let k = if dir >= 0.0 {
            self.times.partition_point(|&tk| tk <= t)
        } else {
            self.times.partition_point(|&tk| tk < t)
        };
        k.checked_sub(1)
    }
}

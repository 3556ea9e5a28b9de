//! The driver's stiffness part: Hairer's test on DOPRI5's steps (`h·λ > 3.25` on 15
//! checks not separated by 6 non-stiff ones), every `every` accepted steps.

use crate::problem::options::Options;
use crate::problem::solution::Stiffness;

/// The test's counters and verdict.
pub(super) struct StiffnessWatch {
    /// Test every `every` accepted steps (`Options::stiffness_check`); `None`: never.
    pub(super) every: Option<usize>,
    /// Stiff and non-stiff checks in a row.
    pub(super) count: (u32, u32),
    /// Accepted steps until the next check.
    pub(super) countdown: usize,
    /// Where the test fired.
    pub(super) verdict: Option<Stiffness>,
}

impl StiffnessWatch {
    /// As `opts` asks.
    pub(super) fn new(opts: &Options) -> Self {
        StiffnessWatch {
            every: opts.stiffness_check,
            count: (0, 0),
            countdown: opts.stiffness_check.unwrap_or(0),
            verdict: None,
        }
    }
}

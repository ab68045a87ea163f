//! The durations one axis can realize: `[t_min, ∞)` minus up to a few blocked intervals.

use crate::cand::Cand;
use crate::math::abs;

/// Most blocked intervals kept per axis.
pub(crate) const MAX_INTERVALS: usize = 3;

/// Durations strictly between `left` and `right` are impossible; `profile` realizes `right`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Interval {
    pub(crate) left: f64,
    pub(crate) right: f64,
    pub(crate) profile: Cand,
}

/// Step-1 result of one axis. Times include the brake pre-trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Block {
    pub(crate) t_min: f64,
    pub(crate) p_min: Cand,
    pub(crate) intervals: [Interval; MAX_INTERVALS],
    pub(crate) n: usize,
}

impl Block {
    pub(crate) const EMPTY: Block = Block {
        t_min: 0.0,
        p_min: Cand::ZERO,
        intervals: [Interval {
            left: 0.0,
            right: 0.0,
            profile: Cand::ZERO,
        }; MAX_INTERVALS],
        n: 0,
    };

    /// Is duration `t` impossible for this axis?
    pub(crate) fn is_blocked(&self, t: f64) -> bool {
        t < self.t_min
            || self.intervals[..self.n]
                .iter()
                .any(|iv| iv.left < t && t < iv.right)
    }

    pub(crate) fn intervals(&self) -> &[Interval] {
        &self.intervals[..self.n]
    }
}

/// Builds the block from valid extremal profiles (durations without brake) into `block`; false
/// if there is none. Their durations, sorted, are the boundaries of the feasible set; which gaps
/// between them are blocked is decided by `feasible` at the gap's midpoint. With a target at
/// rest there is no gap. Intervals past `block.n` are left as they were (never read).
pub(crate) fn make_block(
    cands: &mut [Cand],
    brake: f64,
    rest: bool,
    feasible: &dyn Fn(f64) -> bool,
    block: &mut Block,
) -> bool {
    // Sort by duration.
    for i in 1..cands.len() {
        let mut k = i;
        while k > 0 && cands[k - 1].total() > cands[k].total() {
            cands.swap(k - 1, k);
            k -= 1;
        }
    }
    let Some(&first) = cands.first() else {
        return false;
    };
    block.t_min = first.total() + brake;
    block.p_min = first;
    block.n = 0;
    if rest {
        return true;
    }
    let mut prev = first;
    for &c in cands[1..].iter() {
        if abs(c.total() - prev.total()) <= 1e-12 * c.total() {
            continue;
        }
        let mid = 0.5 * (prev.total() + c.total());
        if !feasible(mid) {
            let left = prev.total() + brake;
            let right = c.total() + brake;
            if block.n > 0 && block.intervals[block.n - 1].right == left {
                block.intervals[block.n - 1].right = right;
                block.intervals[block.n - 1].profile = c;
            } else if block.n < MAX_INTERVALS {
                block.intervals[block.n] = Interval {
                    left,
                    right,
                    profile: c,
                };
                block.n += 1;
            }
        }
        prev = c;
    }
    true
}

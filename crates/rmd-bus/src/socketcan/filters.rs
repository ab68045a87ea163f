//! Turning [`RMD_REPLY_IDS`] and the user's extra filters into the kernel's `CAN_RAW_FILTER`
//! list.
//!
//! A kernel filter `(can_id, can_mask)` accepts a frame whose identifier `x` has
//! `x & can_mask == can_id & can_mask`. An identifier range is covered exactly by aligned
//! power-of-two blocks (0x141..=0x160 becomes 0x141, 0x142/2, 0x144/4, 0x148/8, 0x150/16,
//! 0x160). Every mask also includes `CAN_EFF_FLAG | CAN_RTR_FLAG` with those bits clear in the
//! id, so only standard data frames match: extended and remote frames never reach the process.

use super::kernel_frame::{CAN_EFF_FLAG, CAN_RTR_FLAG, CAN_SFF_MASK};
use super::options::{IdFilter, RMD_REPLY_IDS, SocketCanOptions};

/// `CAN_RAW_FILTER_MAX`: the most filters the kernel accepts on one socket.
pub(crate) const MAX_KERNEL_FILTERS: usize = 512;

/// A filter the options asked for that cannot be expressed.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum FilterProblem {
    /// An id or mask above 0x7FF, or a range whose first id is after its last.
    Invalid(IdFilter),
    /// More filters than the kernel accepts.
    TooMany(usize),
}

/// The kernel filter list, `(can_id, can_mask)` pairs, for `options`.
pub(crate) fn kernel_filters(options: &SocketCanOptions) -> Result<Vec<(u32, u32)>, FilterProblem> {
    let mut filters = Vec::new();
    push_range(&mut filters, *RMD_REPLY_IDS.start(), *RMD_REPLY_IDS.end());
    for &filter in options.extra_filters() {
        match filter {
            IdFilter::Range { first, last } if first <= last && u32::from(last) <= CAN_SFF_MASK => {
                push_range(&mut filters, first, last)
            }
            IdFilter::Masked { id, mask }
                if u32::from(id) <= CAN_SFF_MASK && u32::from(mask) <= CAN_SFF_MASK =>
            {
                filters.push(standard_data_filter(u32::from(id), u32::from(mask)))
            }
            invalid => return Err(FilterProblem::Invalid(invalid)),
        }
    }
    if filters.len() > MAX_KERNEL_FILTERS {
        return Err(FilterProblem::TooMany(filters.len()));
    }
    Ok(filters)
}

fn standard_data_filter(id: u32, mask: u32) -> (u32, u32) {
    (id & mask, mask | CAN_EFF_FLAG | CAN_RTR_FLAG)
}

/// Appends the aligned blocks that exactly cover `first..=last` (both at most 0x7FF).
fn push_range(filters: &mut Vec<(u32, u32)>, first: u16, last: u16) {
    let last = u32::from(last);
    let mut low = u32::from(first);
    while low <= last {
        let mut size = if low == 0 {
            CAN_SFF_MASK + 1
        } else {
            1 << low.trailing_zeros()
        };
        while low + size - 1 > last {
            size >>= 1;
        }
        filters.push(standard_data_filter(low, CAN_SFF_MASK & !(size - 1)));
        low += size;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn accepted(filters: &[(u32, u32)], can_id: u32) -> bool {
        filters.iter().any(|&(id, mask)| can_id & mask == id & mask)
    }

    #[test]
    fn the_default_filters_accept_exactly_the_reply_ids() {
        let filters = kernel_filters(&SocketCanOptions::new()).unwrap();
        assert_eq!(filters.len(), 6);
        for id in 0..=CAN_SFF_MASK {
            assert_eq!(
                accepted(&filters, id),
                (0x141..=0x160).contains(&id),
                "{id:#x}"
            );
        }
    }

    #[test]
    fn extended_and_remote_frames_never_match() {
        let options = SocketCanOptions::new().accept_masked(0, 0);
        let filters = kernel_filters(&options).unwrap();
        assert!(accepted(&filters, 0x123));
        for id in [0x141, 0x123, 0] {
            assert!(!accepted(&filters, id | CAN_EFF_FLAG));
            assert!(!accepted(&filters, id | CAN_RTR_FLAG));
        }
    }

    #[test]
    fn extra_ids_ranges_and_masks_are_added() {
        let options = SocketCanOptions::new()
            .accept_id(0x280)
            .accept_ids(0x0..=0x7FF)
            .accept_masked(0x300, 0x700);
        let filters = kernel_filters(&options).unwrap();
        // 6 reply blocks, 1 exact id, the whole id space as one block, 1 masked.
        assert_eq!(filters.len(), 9);
        assert!(accepted(&filters, 0x280));
        assert!(accepted(&filters, 0x3AB));
        assert!(accepted(&filters, 0x000));
        let only_masked = kernel_filters(&SocketCanOptions::new().accept_masked(0x300, 0x700));
        let only_masked = only_masked.unwrap();
        assert!(accepted(&only_masked, 0x3FF));
        assert!(!accepted(&only_masked, 0x400));
    }

    #[test]
    fn every_range_is_covered_exactly() {
        for (first, last) in [(0, 0), (1, 0x7FF), (0x7FF, 0x7FF), (0x123, 0x456), (5, 6)] {
            let filters = kernel_filters(&SocketCanOptions::new().accept_ids(first..=last));
            let filters = filters.unwrap();
            for id in 0..=CAN_SFF_MASK {
                let expected =
                    (first..=last).contains(&(id as u16)) || (0x141..=0x160).contains(&id);
                assert_eq!(
                    accepted(&filters, id),
                    expected,
                    "{first:#x}..={last:#x}: {id:#x}"
                );
            }
        }
    }

    #[test]
    fn invalid_filters_are_rejected() {
        for options in [
            SocketCanOptions::new().accept_id(0x800),
            SocketCanOptions::new().accept(IdFilter::Range {
                first: 0x10,
                last: 0x0F,
            }),
            SocketCanOptions::new().accept_masked(0x100, 0x800),
        ] {
            let filter = options.extra_filters()[0];
            assert_eq!(
                kernel_filters(&options),
                Err(FilterProblem::Invalid(filter))
            );
        }
    }

    #[test]
    fn too_many_filters_are_rejected() {
        let mut options = SocketCanOptions::new();
        for id in 0..600 {
            options = options.accept_id(id);
        }
        assert_eq!(kernel_filters(&options), Err(FilterProblem::TooMany(606)));
    }
}

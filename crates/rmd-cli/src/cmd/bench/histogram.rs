//! Latency histograms in whole microseconds, the way `cyclictest -h` counts them.
//!
//! cyclictest truncates each latency to whole microseconds and counts bucket `k` for
//! `k <= latency < k + 1` us. The loop's histograms are finer (HdrHistogram, three significant
//! digits: exact to the nanosecond below 2 us, and never coarser than 1/1024 of the value); each
//! of their buckets is counted here in the microsecond bucket of its highest value. Only a bucket
//! that straddles a whole microsecond can land one microsecond high, which needs a bucket wider
//! than 8 ns: above 16 us, an error of at most 1/1024 of the value.

use std::collections::BTreeMap;

use rmd_loop::stats::LatencyHistogram;
use serde_json::{Value, json};

/// Non-empty 1-us buckets of `histogram`: `(k, count)` for `k <= latency < k + 1` us, ascending.
pub(crate) fn whole_us_buckets(histogram: &LatencyHistogram) -> Vec<(u64, u64)> {
    let mut buckets = BTreeMap::new();
    for (value_us, count) in histogram.buckets_us() {
        if count > 0 {
            // value_us is the bucket's highest value in ns / 1000: truncate like cyclictest.
            let k = (value_us * 1000.0).round() as u64 / 1000;
            *buckets.entry(k).or_insert(0) += count;
        }
    }
    buckets.into_iter().collect()
}

/// The buckets as JSON: `[[k, count], ...]`.
pub(crate) fn to_json(buckets: &[(u64, u64)]) -> Value {
    Value::Array(buckets.iter().map(|&(k, n)| json!([k, n])).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::time::Duration;

    #[test]
    fn latencies_are_truncated_to_whole_microseconds() {
        let mut h = LatencyHistogram::new();
        for ns in [0, 999, 1_000, 1_999, 2_500, 7_000, 7_999] {
            h.record(Duration::from_nanos(ns));
        }
        assert_eq!(whole_us_buckets(&h), vec![(0, 2), (1, 2), (2, 1), (7, 2)]);
        assert_eq!(
            to_json(&whole_us_buckets(&h)).to_string(),
            "[[0,2],[1,2],[2,1],[7,2]]"
        );
    }

    #[test]
    fn counts_are_kept_for_long_latencies() {
        let mut h = LatencyHistogram::new();
        for us in 1..=500u64 {
            h.record(Duration::from_micros(us) + Duration::from_nanos(400));
        }
        let b = whole_us_buckets(&h);
        assert_eq!(b.iter().map(|&(_, n)| n).sum::<u64>(), 500);
        // Within the first 16 us the buckets are exact.
        assert!(
            b.iter()
                .take(15)
                .all(|&(k, n)| n == 1 && (1..=15).contains(&k))
        );
    }
}

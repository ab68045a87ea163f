//! Compares the wake-latency histograms that `benches/jitter-vs-cyclictest.sh` collected:
//! cyclictest, `rmd bench jitter` sleeping all the way, and `rmd bench jitter` with a spin margin.
//! Prints a table with the ratios to cyclictest and draws the three distributions as an SVG.
//!
//! ```sh
//! cargo run --release --example jitter_compare -- DIR [--svg FILE] [--caption TEXT] \
//!     [--markdown FILE] [--json FILE]
//! ```
//!
//! `--markdown` writes the table as Markdown (for docs/benchmarks.md), `--json` the pooled
//! percentiles and ratios as one JSON object (for its summary table).
//!
//! DIR holds, for each round R, `round-R-cyclictest.txt` (the output of `cyclictest -q -h N`),
//! `round-R-rmd-sleep.json` and `round-R-rmd-spin.json` (`rmd bench jitter --json`).
//!
//! Like with like: all three are compared on histograms of 1-us buckets (bucket k counts
//! latencies k <= l < k + 1 us: cyclictest truncates to whole microseconds, and `rmd bench
//! jitter` reports its histogram the same way), pooled over the rounds, with one percentile rule:
//! the q-quantile lies in the first bucket k where the cumulative count reaches
//! r = ceil(q * N), and is placed within it by linear interpolation,
//! p_q = k + (r - C(k-1)) / n(k), where C(k-1) counts the samples below k and n(k) those in k
//! (the exact order statistic is within [k, k + 1)). Min and max are the lowest and highest
//! non-empty buckets (whole microseconds, as cyclictest prints them).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::prelude::*;

/// A latency histogram in whole microseconds.
#[derive(Clone, Debug, Default, PartialEq)]
struct Histogram {
    /// Bucket k: latencies k <= l < k + 1 us.
    buckets: BTreeMap<u64, u64>,
    /// Samples beyond the histogram's range (cyclictest's overflows), all >= `overflow_from`.
    overflows: u64,
    overflow_from: u64,
}

impl Histogram {
    fn count(&self) -> u64 {
        self.buckets.values().sum::<u64>() + self.overflows
    }

    fn add(&mut self, other: &Histogram) {
        for (k, n) in &other.buckets {
            *self.buckets.entry(*k).or_insert(0) += n;
        }
        self.overflows += other.overflows;
        self.overflow_from = self.overflow_from.max(other.overflow_from);
    }

    /// The interpolated q-quantile (see the module doc); `None` if it falls among the overflows
    /// (beyond the histogram) or the histogram is empty.
    fn quantile(&self, q: f64) -> Option<f64> {
        let n = self.count();
        if n == 0 {
            return None;
        }
        let rank = ((q * n as f64).ceil() as u64).clamp(1, n);
        let mut below = 0;
        for (&k, &count) in &self.buckets {
            if below + count >= rank {
                return Some(k as f64 + (rank - below) as f64 / count as f64);
            }
            below += count;
        }
        None
    }

    fn min(&self) -> Option<u64> {
        self.buckets.keys().next().copied()
    }

    fn max(&self) -> Option<u64> {
        if self.overflows > 0 {
            return None;
        }
        self.buckets.keys().next_back().copied()
    }
}

/// Parses the output of `cyclictest -q -h N` (one thread): the histogram lines `KKKKKK NNNNNN`
/// and `# Histogram Overflows: NNNNN`.
fn parse_cyclictest(text: &str) -> Result<Histogram, String> {
    let mut h = Histogram::default();
    let mut lines = 0;
    for line in text.lines() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("# Histogram Overflows:") {
            h.overflows = first_number(rest)?;
            continue;
        }
        if line.starts_with('#') || line.is_empty() {
            continue;
        }
        let mut fields = line.split_whitespace();
        let (Some(k), Some(n)) = (fields.next(), fields.next()) else {
            continue;
        };
        let (Ok(k), Ok(n)) = (k.parse::<u64>(), n.parse::<u64>()) else {
            continue;
        };
        lines += 1;
        h.overflow_from = h.overflow_from.max(k + 1);
        if n > 0 {
            h.buckets.insert(k, n);
        }
    }
    if lines == 0 {
        return Err("no histogram lines (was cyclictest run with -h?)".to_string());
    }
    Ok(h)
}

fn first_number(text: &str) -> Result<u64, String> {
    text.split_whitespace()
        .next()
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| format!("not a number: `{text}`"))
}

/// One `rmd bench jitter --json` object: its 1-us histogram and its own exact percentiles.
#[derive(Clone, Debug)]
struct RmdRun {
    histogram: Histogram,
    exact_p99_us: f64,
    exact_max_us: f64,
    spin_us: f64,
}

fn parse_rmd(text: &str) -> Result<RmdRun, String> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
    let mut h = Histogram::default();
    let buckets = v["histogram_us"]
        .as_array()
        .ok_or("no `histogram_us` array")?;
    for b in buckets {
        let (Some(k), Some(n)) = (b[0].as_u64(), b[1].as_u64()) else {
            return Err(format!("bad histogram bucket {b}"));
        };
        *h.buckets.entry(k).or_insert(0) += n;
    }
    let ticks = v["ticks"].as_u64().ok_or("no `ticks`")?;
    if h.count() != ticks {
        return Err(format!(
            "histogram holds {} samples, ticks {ticks}",
            h.count()
        ));
    }
    Ok(RmdRun {
        histogram: h,
        exact_p99_us: v["wake_latency_us"]["p99"].as_f64().ok_or("no p99")?,
        exact_max_us: v["wake_latency_us"]["max"].as_f64().ok_or("no max")?,
        spin_us: v["spin_us"].as_f64().unwrap_or(0.0),
    })
}

/// The three tools, in table order.
const TOOLS: [&str; 3] = ["cyclictest", "rmd sleep-only", "rmd sleep+spin"];
const QUANTILES: [(f64, &str); 4] = [(0.5, "p50"), (0.9, "p90"), (0.99, "p99"), (0.999, "p99.9")];

struct Rounds {
    pooled: [Histogram; 3],
    per_round: Vec<[Histogram; 3]>,
    rmd_exact: Vec<[RmdRun; 2]>,
}

fn load(dir: &Path) -> Result<Rounds, String> {
    let mut per_round = Vec::new();
    let mut rmd_exact = Vec::new();
    for r in 1.. {
        let cyc = dir.join(format!("round-{r}-cyclictest.txt"));
        if !cyc.exists() {
            break;
        }
        let read =
            |p: PathBuf| std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()));
        let c =
            parse_cyclictest(&read(cyc.clone())?).map_err(|e| format!("{}: {e}", cyc.display()))?;
        let sleep = parse_rmd(&read(dir.join(format!("round-{r}-rmd-sleep.json")))?)
            .map_err(|e| format!("round {r} rmd sleep: {e}"))?;
        let spin = parse_rmd(&read(dir.join(format!("round-{r}-rmd-spin.json")))?)
            .map_err(|e| format!("round {r} rmd spin: {e}"))?;
        per_round.push([c, sleep.histogram.clone(), spin.histogram.clone()]);
        rmd_exact.push([sleep, spin]);
    }
    if per_round.is_empty() {
        return Err(format!("no round-1-cyclictest.txt in {}", dir.display()));
    }
    let mut pooled: [Histogram; 3] = Default::default();
    for round in &per_round {
        for (p, h) in pooled.iter_mut().zip(round) {
            p.add(h);
        }
    }
    Ok(Rounds {
        pooled,
        per_round,
        rmd_exact,
    })
}

fn show(v: Option<f64>) -> String {
    v.map_or_else(|| "overflow".to_string(), |x| format!("{x:.2}"))
}

fn ratio(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => Some(a / b),
        _ => None,
    }
}

fn table(r: &Rounds) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "wake latency in us, {} round(s) pooled; percentiles from 1-us histograms (bucket k = [k, k+1) us), interpolated within the bucket",
        r.per_round.len()
    );
    let _ = write!(out, "{:<16}{:>9}{:>6}", "tool", "samples", "min");
    for (_, name) in QUANTILES {
        let _ = write!(out, "{name:>9}");
    }
    let _ = writeln!(out, "{:>7}{:>12}{:>14}", "max", "p99 ratio", "p99.9 ratio");
    let base = &r.pooled[0];
    for (name, h) in TOOLS.iter().zip(&r.pooled) {
        let _ = write!(
            out,
            "{name:<16}{:>9}{:>6}",
            h.count(),
            h.min().map_or("-".to_string(), |m| m.to_string())
        );
        for (q, _) in QUANTILES {
            let _ = write!(out, "{:>9}", show(h.quantile(q)));
        }
        let _ = writeln!(
            out,
            "{:>7}{:>12}{:>14}",
            h.max().map_or("ovf".to_string(), |m| m.to_string()),
            show(ratio(h.quantile(0.99), base.quantile(0.99))),
            show(ratio(h.quantile(0.999), base.quantile(0.999))),
        );
    }
    let sleep = ratio(r.pooled[1].quantile(0.99), base.quantile(0.99));
    let spin = ratio(r.pooled[2].quantile(0.99), base.quantile(0.99));
    let verdict = |v: Option<f64>, ok: fn(f64) -> bool| match v {
        Some(x) if ok(x) => format!("{x:.3}: met"),
        Some(x) => format!("{x:.3}: NOT met"),
        None => "n/a".to_string(),
    };
    let _ = writeln!(
        out,
        "goal: sleep-only p99 at most 1.1x cyclictest's (ratio <= 1.10): {}",
        verdict(sleep, |x| x <= 1.1)
    );
    let _ = writeln!(
        out,
        "goal: sleep+spin p99 at most 1/5 of cyclictest's (ratio <= 0.20): {}",
        verdict(spin, |x| x <= 0.2)
    );
    let _ = writeln!(
        out,
        "per round, p99 (us): cyclictest / rmd sleep-only / rmd sleep+spin   [rmd's own HdrHistogram p99 and max: sleep | spin]"
    );
    for (i, (round, exact)) in r.per_round.iter().zip(&r.rmd_exact).enumerate() {
        let _ = writeln!(
            out,
            "  round {}: {} / {} / {}   [{:.3} max {:.1} | {:.3} max {:.1}]",
            i + 1,
            show(round[0].quantile(0.99)),
            show(round[1].quantile(0.99)),
            show(round[2].quantile(0.99)),
            exact[0].exact_p99_us,
            exact[0].exact_max_us,
            exact[1].exact_p99_us,
            exact[1].exact_max_us,
        );
    }
    out
}

/// The pooled table in Markdown.
fn markdown(r: &Rounds) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| tool | samples | min | p50 | p90 | p99 | p99.9 | max | p99 ratio | p99.9 ratio |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|");
    let base = &r.pooled[0];
    for (name, h) in TOOLS.iter().zip(&r.pooled) {
        let _ = write!(
            out,
            "| {name} | {} | {} |",
            h.count(),
            h.min().map_or("-".to_string(), |m| m.to_string())
        );
        for (q, _) in QUANTILES {
            let _ = write!(out, " {} |", show(h.quantile(q)));
        }
        let _ = writeln!(
            out,
            " {} | {} | {} |",
            h.max().map_or("overflow".to_string(), |m| m.to_string()),
            show(ratio(h.quantile(0.99), base.quantile(0.99))),
            show(ratio(h.quantile(0.999), base.quantile(0.999))),
        );
    }
    let _ = writeln!(
        out,
        "\np99 per round (cyclictest / rmd sleep-only / rmd sleep+spin, us): {}",
        r.per_round
            .iter()
            .map(|round| format!(
                "{} / {} / {}",
                show(round[0].quantile(0.99)),
                show(round[1].quantile(0.99)),
                show(round[2].quantile(0.99))
            ))
            .collect::<Vec<_>>()
            .join("; ")
    );
    out
}

/// The pooled percentiles and the ratios to cyclictest, as JSON.
fn summary_json(r: &Rounds) -> serde_json::Value {
    let base = &r.pooled[0];
    let tool = |h: &Histogram| {
        serde_json::json!({
            "samples": h.count(),
            "p50": h.quantile(0.5),
            "p99": h.quantile(0.99),
            "p999": h.quantile(0.999),
            "max": h.max(),
            "p99_ratio": ratio(h.quantile(0.99), base.quantile(0.99)),
            "p999_ratio": ratio(h.quantile(0.999), base.quantile(0.999)),
        })
    };
    serde_json::json!({
        "rounds": r.per_round.len(),
        "spin_us": r.rmd_exact.first().map(|x| x[1].spin_us),
        "cyclictest": tool(&r.pooled[0]),
        "rmd_sleep": tool(&r.pooled[1]),
        "rmd_spin": tool(&r.pooled[2]),
    })
}

/// Draws the pooled distributions: fraction of ticks per 1-us bucket, log scale.
fn plot(r: &Rounds, path: &Path, caption: &str) -> Result<(), Box<dyn std::error::Error>> {
    let highest = r
        .pooled
        .iter()
        .filter_map(|h| h.buckets.keys().next_back().copied())
        .max()
        .unwrap_or(1);
    // Show the body of every distribution (three times the largest p99, at least 20 us); the
    // legend counts the ticks beyond, and the table has the tail.
    let p99 = r
        .pooled
        .iter()
        .filter_map(|h| h.quantile(0.99))
        .fold(0.0f64, f64::max);
    let x_max = (p99 * 3.0).max(20.0).min(highest as f64 + 1.0).ceil();
    let floor = 1e-6;
    let root = SVGBackend::new(path, (960, 540)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0f64..x_max, (floor..1.0f64).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("wake latency (us), 1-us buckets")
        .y_desc("fraction of ticks")
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .draw()?;
    let styles = [
        RED.stroke_width(3),
        BLUE.stroke_width(2),
        RGBColor(0, 150, 0).stroke_width(2),
    ];
    for ((name, h), style) in TOOLS.iter().zip(&r.pooled).zip(styles) {
        let n = h.count().max(1) as f64;
        let beyond: u64 =
            h.buckets.range(x_max as u64..).map(|(_, c)| c).sum::<u64>() + h.overflows;
        let mut points = Vec::new();
        for k in 0..x_max as u64 {
            let f = h
                .buckets
                .get(&k)
                .map_or(floor, |&c| (c as f64 / n).max(floor));
            points.push((k as f64, f));
            points.push((k as f64 + 1.0, f));
        }
        chart
            .draw_series(LineSeries::new(points, style))?
            .label(format!(
                "{name}: p99 {} us, max {} us, {beyond} tick(s) beyond {x_max} us",
                show(h.quantile(0.99)),
                h.max().map_or("overflow".to_string(), |m| m.to_string()),
            ))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

fn main() -> std::process::ExitCode {
    let mut args = std::env::args().skip(1);
    let mut dir = None;
    let mut svg = None;
    let mut md = None;
    let mut json = None;
    let mut caption = "wake latency: cyclictest vs rmd bench jitter".to_string();
    while let Some(a) = args.next() {
        match a.as_str() {
            "--svg" => svg = args.next().map(PathBuf::from),
            "--markdown" => md = args.next().map(PathBuf::from),
            "--json" => json = args.next().map(PathBuf::from),
            "--caption" => caption = args.next().unwrap_or_default(),
            _ => dir = Some(PathBuf::from(a)),
        }
    }
    let Some(dir) = dir else {
        eprintln!(
            "usage: jitter_compare DIR [--svg FILE] [--caption TEXT] [--markdown FILE] [--json FILE]"
        );
        return std::process::ExitCode::from(2);
    };
    let rounds = match load(&dir) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return std::process::ExitCode::FAILURE;
        }
    };
    print!("{}", table(&rounds));
    if let Some(spin) = rounds.rmd_exact.first().map(|r| r[1].spin_us) {
        println!("(rmd sleep+spin: spin margin {spin} us)");
    }
    for (path, text) in [
        (md, markdown(&rounds)),
        (json, format!("{}\n", summary_json(&rounds))),
    ] {
        if let Some(path) = path
            && let Err(e) = std::fs::write(&path, text)
        {
            eprintln!("error: cannot write {}: {e}", path.display());
            return std::process::ExitCode::FAILURE;
        }
    }
    if let Some(svg) = svg {
        if let Err(e) = plot(&rounds, &svg, &caption) {
            eprintln!("error: cannot draw {}: {e}", svg.display());
            return std::process::ExitCode::FAILURE;
        }
        println!("plot: {}", svg.display());
    }
    std::process::ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hist(buckets: &[(u64, u64)]) -> Histogram {
        Histogram {
            buckets: buckets.iter().copied().collect(),
            ..Histogram::default()
        }
    }

    #[test]
    fn quantiles_follow_the_nearest_rank_with_interpolation() {
        // 100 samples: 50 in [3,4), 40 in [4,5), 10 in [9,10).
        let h = hist(&[(3, 50), (4, 40), (9, 10)]);
        assert_eq!(h.quantile(0.5), Some(4.0)); // rank 50: the last sample of bucket 3
        assert_eq!(h.quantile(0.9), Some(5.0)); // rank 90: the last of bucket 4
        assert_eq!(h.quantile(0.91), Some(9.1)); // rank 91: the first of bucket 9
        assert_eq!(h.quantile(0.99), Some(9.9));
        assert_eq!((h.min(), h.max()), (Some(3), Some(9)));
        assert_eq!(Histogram::default().quantile(0.5), None);
    }

    #[test]
    fn overflows_count_and_hide_the_tail() {
        let mut h = hist(&[(2, 98)]);
        h.overflows = 2;
        h.overflow_from = 100;
        assert_eq!(h.count(), 100);
        assert_eq!(h.quantile(0.98), Some(3.0));
        assert_eq!(h.quantile(0.99), None);
        assert_eq!(h.max(), None);
    }

    #[test]
    fn cyclictest_output_is_parsed() {
        let text = "# /dev/cpu_dma_latency set to 0us\n# Histogram\n000000 000000\n000001 000003\n\
                    000002 000007\n000003 000000\n# Total: 000000010\n# Min Latencies: 00001\n\
                    # Avg Latencies: 00001\n# Max Latencies: 00002\n# Histogram Overflows: 00001\n";
        let h = parse_cyclictest(text).unwrap();
        assert_eq!(
            h,
            Histogram {
                buckets: [(1, 3), (2, 7)].into_iter().collect(),
                overflows: 1,
                overflow_from: 4,
            }
        );
        assert!(parse_cyclictest("T: 0 ( 1) P:80 I:1000 C: 10 Min: 1").is_err());
    }

    #[test]
    fn the_markdown_and_json_summaries_carry_the_pooled_ratios() {
        let rounds = Rounds {
            pooled: [
                hist(&[(10, 99), (40, 1)]),
                hist(&[(11, 99), (44, 1)]),
                hist(&[(0, 100)]),
            ],
            per_round: vec![[
                hist(&[(10, 99), (40, 1)]),
                hist(&[(11, 99), (44, 1)]),
                hist(&[(0, 100)]),
            ]],
            rmd_exact: Vec::new(),
        };
        let v = summary_json(&rounds);
        assert_eq!(v["cyclictest"]["p99"], 11.0);
        assert_eq!(v["rmd_sleep"]["p99"], 12.0);
        assert!((v["rmd_sleep"]["p99_ratio"].as_f64().unwrap() - 12.0 / 11.0).abs() < 1e-12);
        assert_eq!(v["rmd_spin"]["max"], 0);
        let md = markdown(&rounds);
        assert!(md.starts_with("| tool | samples |"), "{md}");
        assert!(md.contains("| rmd sleep-only | 100 | 11 | 11.51 |"), "{md}");
        assert!(md.contains("p99 per round"), "{md}");
    }

    #[test]
    fn rmd_json_is_parsed_and_checked() {
        let text = r#"{"ticks":5,"deadline_misses":0,"wake_latency_us":{"p99":3.2,"max":3.3},"spin_us":50.0,"histogram_us":[[1,2],[3,3]]}"#;
        let r = parse_rmd(text).unwrap();
        assert_eq!(r.histogram, hist(&[(1, 2), (3, 3)]));
        assert_eq!(
            (r.exact_p99_us, r.exact_max_us, r.spin_us),
            (3.2, 3.3, 50.0)
        );
        assert!(parse_rmd(&text.replace("\"ticks\":5", "\"ticks\":6")).is_err());
    }
}

//! Turns the raw outputs of `benches/all-figures.sh` into the Markdown tables of
//! docs/benchmarks.md and the rate plot in docs/img/. Every number comes from a file the
//! benchmarks wrote in the same run; nothing is typed in by hand.
//!
//! ```sh
//! cargo run --release --example bench_figures -- tick CRITERION_DIR TICK_LOG
//! cargo run --release --example bench_figures -- rate RATE.jsonl [--svg FILE] [--caption TEXT]
//! cargo run --release --example bench_figures -- loop REPORT.json...
//! cargo run --release --example bench_figures -- criterion CRITERION_DIR [PREFIX...]
//! cargo run --release --example bench_figures -- summary --tick CRITERION_DIR --tick-log LOG \
//!     --jitter JITTER.json --rate RATE.jsonl
//! ```
//!
//! - `tick`: the criterion means of `cargo bench --bench tick` (`CRITERION_DIR` is
//!   `target/criterion`) and the allocations per tick it printed (`TICK_LOG`);
//! - `rate`: the `rmd bench rate --json` objects (one per bus count, one per line): a table,
//!   and the plot of the headline and zero-miss rates against the wire limit by bus count;
//! - `loop`: `rmd bench loop --json` reports, one column each;
//! - `criterion`: the mean of every criterion benchmark whose id starts with one of the
//!   prefixes (all without any), one row each;
//! - `summary`: the headline table (one row per figure of issue 17).
//!
//! Plots use `plotters` (already the project's plotting crate, pure Rust, SVG without fonts or
//! system libraries, so a fresh machine needs nothing installed for them).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use serde_json::Value;

type Error = Box<dyn std::error::Error>;

fn read(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()).into())
}

/// Every JSON object of a JSON Lines file.
fn json_lines(path: &Path) -> Result<Vec<Value>, Error> {
    read(path)?
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| serde_json::from_str(l).map_err(|e| format!("{}: {e}", path.display()).into()))
        .collect()
}

fn num(v: &Value) -> Option<f64> {
    v.as_f64()
}

fn fmt(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".to_string(), |x| format!("{x:.digits$}"))
}

fn pct(v: Option<f64>) -> String {
    v.map_or("-".to_string(), |x| format!("{:.1}%", 100.0 * x))
}

// ---- tick ---------------------------------------------------------------------------------

const TICK_CONFIGS: [&str; 2] = ["1x4", "4x4"];
const TICK_VIEWS: [&str; 3] = ["loop+sim", "sim alone", "loop alone"];

/// The criterion mean of `tick/<name>`, microseconds.
fn criterion_mean_us(dir: &Path, name: &str) -> Option<f64> {
    let path = dir
        .join("tick")
        .join(name)
        .join("new")
        .join("estimates.json");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()?;
    v["mean"]["point_estimate"].as_f64().map(|ns| ns / 1000.0)
}

/// `NAME: N allocations in T ticks` lines of the tick bench's log.
fn allocations(log: &str, name: &str) -> Option<(u64, u64)> {
    let line = log.lines().find(|l| l.starts_with(&format!("{name}: ")))?;
    let mut words = line[name.len() + 2..].split_whitespace();
    let n = words.next()?.parse().ok()?;
    let ticks = words.nth(2)?.parse().ok()?;
    Some((n, ticks))
}

/// Instructions per tick of `config` in `benches/tick-instructions.sh --json`'s output.
fn instructions_per_tick(instructions: &Value, config: &str) -> Option<f64> {
    instructions["ir_per_tick"][config].as_f64()
}

/// The tick table: criterion's means, the allocations, and (when `instructions` holds the
/// output of `benches/tick-instructions.sh --json`) the loop alone's instructions per tick and
/// the time per instruction, which shows when the machine rather than the code moved.
fn tick_table(dir: &Path, log: &str, instructions: Option<&Value>) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| configuration | loop + sim | sim alone | **loop alone** (the framework's overhead) | allocations per tick (loop alone) | instructions per tick (loop alone, callgrind) | ns per instruction |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    for config in TICK_CONFIGS {
        let means: Vec<Option<f64>> = TICK_VIEWS
            .iter()
            .map(|view| criterion_mean_us(dir, &format!("{view} {config}")))
            .collect();
        let us: Vec<String> = means.iter().map(|m| fmt(*m, 2)).collect();
        let alloc = allocations(log, &format!("loop alone {config}"))
            .map_or("-".to_string(), |(n, t)| format!("{n} in {t} ticks"));
        let ir = instructions.and_then(|v| instructions_per_tick(v, config));
        let ns_per_ir = ir.zip(means[2]).map(|(ir, us)| us * 1000.0 / ir);
        let _ = writeln!(
            out,
            "| {} bus(es) x {} motors | {} us | {} us | **{} us** | {alloc} | {} | {} |",
            &config[..1],
            &config[2..],
            us[0],
            us[1],
            us[2],
            fmt(ir, 0),
            fmt(ns_per_ir, 3)
        );
    }
    out
}

// ---- rate ---------------------------------------------------------------------------------

/// One bus count of `rmd bench rate --json`.
struct RateRow {
    buses: u64,
    wire_limit: Option<f64>,
    rate: Option<f64>,
    rate_of_limit: Option<f64>,
    zero: Option<f64>,
    zero_of_limit: Option<f64>,
    added_p50: Option<f64>,
    added_p99: Option<f64>,
    trials: usize,
    sim_late: u64,
    /// Missed slots that were the simulator's (not counted against the loop).
    sim_missed: u64,
}

fn rate_rows(objects: &[Value]) -> Vec<RateRow> {
    objects
        .iter()
        .map(|v| RateRow {
            buses: v["buses"].as_u64().unwrap_or(0),
            wire_limit: num(&v["wire_limit_hz"]),
            rate: num(&v["rate_hz"]),
            rate_of_limit: num(&v["rate_of_wire_limit"]),
            zero: num(&v["zero_miss_rate_hz"]),
            zero_of_limit: num(&v["zero_miss_of_wire_limit"]),
            added_p50: num(&v["loop_added_us"]["p50"]),
            added_p99: num(&v["loop_added_us"]["p99"]),
            trials: v["trials"].as_array().map_or(0, Vec::len),
            sim_late: v["trials"].as_array().map_or(0, |ts| {
                ts.iter().filter_map(|t| t["sim_late_items"].as_u64()).sum()
            }),
            sim_missed: v["trials"].as_array().map_or(0, |ts| {
                ts.iter()
                    .filter_map(|t| t["simulator_missed_slots"].as_u64())
                    .sum()
            }),
        })
        .collect()
}

fn rate_table(rows: &[RateRow]) -> String {
    let one = rows.iter().find(|r| r.buses == 1).and_then(|r| r.rate);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| buses x 4 motors | wire limit | headline rate (<= 0.1% missed) | of the limit | zero-miss rate | of the limit | loop added p50 / p99 | headline vs 1 bus | trials | simulator late: items / missed slots |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            out,
            "| {} | {} Hz | **{} Hz** | **{}** | {} Hz | {} | {} / {} us | {} | {} | {} / {} |",
            r.buses,
            fmt(r.wire_limit, 1),
            fmt(r.rate, 1),
            pct(r.rate_of_limit),
            fmt(r.zero, 1),
            pct(r.zero_of_limit),
            fmt(r.added_p50, 2),
            fmt(r.added_p99, 2),
            pct(r.rate.zip(one).map(|(r, o)| r / o)),
            r.trials,
            r.sim_late,
            r.sim_missed,
        );
    }
    out
}

/// One rate of a row, for a plotted series.
type RateOf = Box<dyn Fn(&RateRow) -> Option<f64>>;

/// The headline and zero-miss rates against the wire limit, by bus count.
fn rate_plot(rows: &[RateRow], path: &Path, caption: &str) -> Result<(), Error> {
    let top = rows
        .iter()
        .flat_map(|r| [r.wire_limit, r.rate, r.zero])
        .flatten()
        .fold(0.0f64, f64::max)
        .max(1.0);
    let root = SVGBackend::new(path, (900, 500)).into_drawing_area();
    root.fill(&WHITE)?;
    let n = rows.len().max(1);
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5f64..n as f64 - 0.5, 0f64..top * 1.35)?;
    let labels: Vec<String> = rows
        .iter()
        .map(|r| format!("{} bus(es)", r.buses))
        .collect();
    chart
        .configure_mesh()
        .disable_x_mesh()
        .light_line_style(RGBColor(240, 240, 240))
        .x_labels(n)
        .x_label_formatter(&|x| {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 {
                labels.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .y_desc("loop rate (Hz)")
        .x_desc("simulated 1 Mbit/s buses, 4 motors each, one loop thread")
        .draw()?;
    let series: [(&str, RateOf, RGBColor, f64); 3] = [
        (
            "wire limit of the frames sent",
            Box::new(|r| r.wire_limit),
            BLACK,
            -0.25,
        ),
        (
            "headline: at most 0.1% of ticks missed",
            Box::new(|r| r.rate),
            BLUE,
            0.0,
        ),
        (
            "zero misses",
            Box::new(|r| r.zero),
            RGBColor(0, 150, 0),
            0.25,
        ),
    ];
    for (name, value, color, offset) in series {
        let bars: Vec<_> = rows
            .iter()
            .enumerate()
            .filter_map(|(i, r)| value(r).map(|v| (i as f64 + offset, v)))
            .collect();
        chart
            .draw_series(bars.iter().map(|&(x, v)| {
                Rectangle::new([(x - 0.1, 0.0), (x + 0.1, v)], color.mix(0.8).filled())
            }))?
            .label(name)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], color.filled()));
        chart.draw_series(bars.iter().map(|&(x, v)| {
            Text::new(
                format!("{v:.0}"),
                (x - 0.09, v + top * 0.05),
                ("sans-serif", 12),
            )
        }))?;
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

// ---- loop ---------------------------------------------------------------------------------

fn loop_table(reports: &[Value]) -> String {
    let mut out = String::new();
    let heads: Vec<String> = reports
        .iter()
        .map(|v| {
            format!(
                "{} bus(es) x {} motors",
                v["bench"]["buses"], v["bench"]["motors_per_bus"]
            )
        })
        .collect();
    let _ = writeln!(out, "| | {} |", heads.join(" | "));
    let _ = writeln!(out, "|---|{}", "---|".repeat(reports.len()));
    let row = |name: &str, f: &dyn Fn(&Value) -> String| {
        format!(
            "| {name} | {} |\n",
            reports.iter().map(f).collect::<Vec<_>>().join(" | ")
        )
    };
    let p = |key: &'static str, fields: &'static [&'static str]| {
        move |v: &Value| {
            fields
                .iter()
                .map(|f| fmt(num(&v[key][*f]), 1))
                .collect::<Vec<_>>()
                .join(" / ")
        }
    };
    out += &row("ticks", &|v| v["ticks"].to_string());
    out += &row("missed ticks / deadline misses / skipped", &|v| {
        format!(
            "{} / {} / {}",
            v["missed_ticks"], v["deadline_misses"], v["skipped_ticks"]
        )
    });
    out += &row("missing / late replies", &|v| {
        format!("{} / {}", v["missing_replies"], v["late_replies"])
    });
    out += &row(
        "wake latency p50 / p99 / p99.9 / max (us)",
        &p("wake_latency_us", &["p50", "p99", "p999", "max"]),
    );
    out += &row(
        "round trip p50 / p99 / max (us)",
        &p("round_trip_us", &["p50", "p99", "max"]),
    );
    out += &row(
        "controller p50 / p99 / max (us)",
        &p("controller_us", &["p50", "p99", "max"]),
    );
    out += &row(
        "loop added p50 / p99 / max (us)",
        &p("loop_added_us", &["p50", "p99", "max"]),
    );
    out += &row("PD tracking error rms / max (deg)", &|v| {
        format!(
            "{} / {}",
            fmt(num(&v["bench"]["tracking_rms_error_deg"]), 3),
            fmt(num(&v["bench"]["tracking_max_error_deg"]), 3)
        )
    });
    out += &row("real-time", &|v| {
        v["realtime"].as_str().unwrap_or("-").to_string()
    });
    out
}

// ---- criterion ----------------------------------------------------------------------------

/// Every criterion benchmark under `dir`: its id and mean, microseconds.
fn criterion_means(dir: &Path) -> Vec<(String, f64)> {
    fn walk(dir: &Path, out: &mut Vec<(String, f64)>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if !path.is_dir() {
                continue;
            }
            if path.file_name().is_some_and(|n| n == "new") {
                let json = |name: &str| -> Option<Value> {
                    serde_json::from_str(&std::fs::read_to_string(path.join(name)).ok()?).ok()
                };
                if let (Some(id), Some(estimates)) =
                    (json("benchmark.json"), json("estimates.json"))
                    && let (Some(id), Some(ns)) = (
                        id["full_id"].as_str(),
                        estimates["mean"]["point_estimate"].as_f64(),
                    )
                {
                    out.push((id.to_string(), ns / 1000.0));
                }
            } else {
                walk(&path, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, &mut out);
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

fn criterion_table(means: &[(String, f64)], prefixes: &[String]) -> String {
    let mut out = String::from("| benchmark (criterion id) | mean |\n|---|---|\n");
    for (id, us) in means {
        if prefixes.is_empty() || prefixes.iter().any(|p| id.starts_with(p.as_str())) {
            let shown = if *us < 1.0 {
                format!("{:.1} ns", us * 1000.0)
            } else {
                format!("{us:.2} us")
            };
            let _ = writeln!(out, "| {id} | {shown} |");
        }
    }
    out
}

// ---- summary ------------------------------------------------------------------------------

struct Summary {
    tick_dir: PathBuf,
    tick_log: String,
    jitter: Option<Value>,
    rate: Vec<RateRow>,
}

fn summary_table(s: &Summary) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "| figure | goal (issue 17) | result |");
    let _ = writeln!(out, "|---|---|---|");
    let j = |tool: &str, key: &str| s.jitter.as_ref().and_then(|v| num(&v[tool][key]));
    let verdict = |ok: Option<bool>| match ok {
        Some(true) => "met",
        Some(false) => "**not met**",
        None => "n/a",
    };
    let sleep = j("rmd_sleep", "p99_ratio");
    let _ = writeln!(
        out,
        "| wake latency p99, sleep only, vs cyclictest (defaults: it holds /dev/cpu_dma_latency; so does the loop) | <= 1.1x | {} us vs {} us: **{}x** ({}) |",
        fmt(j("rmd_sleep", "p99"), 2),
        fmt(j("cyclictest", "p99"), 2),
        fmt(sleep, 2),
        verdict(sleep.map(|x| x <= 1.1))
    );
    let spin = j("rmd_spin", "p99_ratio");
    let _ = writeln!(
        out,
        "| wake latency p99, sleep + {} us spin, vs cyclictest | keep (0.004x) | {} us: **{}x** |",
        s.jitter
            .as_ref()
            .and_then(|v| num(&v["spin_us"]))
            .map_or("-".to_string(), |x| format!("{x:.0}")),
        fmt(j("rmd_spin", "p99"), 2),
        fmt(spin, 3),
    );
    let one = s.rate.iter().find(|r| r.buses == 1);
    let _ = writeln!(
        out,
        "| highest rate with at most 0.1% of ticks missed, 1 bus x 4 motors | >= 95% of the wire limit | {} Hz = **{}** of {} Hz ({}) |",
        fmt(one.and_then(|r| r.rate), 1),
        pct(one.and_then(|r| r.rate_of_limit)),
        fmt(one.and_then(|r| r.wire_limit), 1),
        verdict(one.and_then(|r| r.rate_of_limit).map(|x| x >= 0.95))
    );
    let _ = writeln!(
        out,
        "| highest rate with zero misses, 1 bus x 4 motors | (reported) | {} Hz = {} of the wire limit |",
        fmt(one.and_then(|r| r.zero), 1),
        pct(one.and_then(|r| r.zero_of_limit)),
    );
    let _ = writeln!(
        out,
        "| loop added per exchange (last reply to ready for the next frame), 1 bus x 4 | p99 <= 5 us | p50 {} us, p99 **{} us** ({}) |",
        fmt(one.and_then(|r| r.added_p50), 2),
        fmt(one.and_then(|r| r.added_p99), 2),
        verdict(one.and_then(|r| r.added_p99).map(|x| x <= 5.0))
    );
    let four = s.rate.iter().find(|r| r.buses == 4);
    let vs = four
        .and_then(|f| f.rate)
        .zip(one.and_then(|o| o.rate))
        .map(|(f, o)| f / o);
    let _ = writeln!(
        out,
        "| 4 buses x 4 motors vs 1 bus, headline rate, one loop thread | >= 95% | {} Hz vs {} Hz: **{}** ({}) |",
        fmt(four.and_then(|r| r.rate), 1),
        fmt(one.and_then(|r| r.rate), 1),
        pct(vs),
        verdict(vs.map(|x| x >= 0.95))
    );
    let alloc = allocations(&s.tick_log, "loop alone 1x4");
    let _ = writeln!(
        out,
        "| tick overhead, loop alone, 1 x 4 (criterion mean) | keep (0.49 us), 0 allocations | **{} us**, {} allocations in {} ticks |",
        fmt(criterion_mean_us(&s.tick_dir, "loop alone 1x4"), 2),
        alloc.map_or("-".to_string(), |(n, _)| n.to_string()),
        alloc.map_or("-".to_string(), |(_, t)| t.to_string()),
    );
    let _ = writeln!(
        out,
        "| tick overhead, loop alone, 4 x 4 (criterion mean) | (reported) | {} us |",
        fmt(criterion_mean_us(&s.tick_dir, "loop alone 4x4"), 2),
    );
    out
}

// ---- main ---------------------------------------------------------------------------------

fn run(args: &[String]) -> Result<(), Error> {
    let usage = "usage: bench_figures tick CRITERION_DIR TICK_LOG [INSTRUCTIONS.json] | rate RATE.jsonl [--svg FILE] \
                 [--caption TEXT] | loop REPORT.json... | criterion CRITERION_DIR [PREFIX...] | \
                 summary --tick DIR --tick-log LOG --jitter JSON --rate JSONL";
    let (command, rest) = args.split_first().ok_or(usage)?;
    let flag = |name: &str| {
        rest.iter()
            .position(|a| a == name)
            .and_then(|i| rest.get(i + 1))
            .map(PathBuf::from)
    };
    match command.as_str() {
        "tick" => {
            let (dir, log, instructions) = match rest {
                [dir, log] => (dir, log, None),
                [dir, log, instructions] => (
                    dir,
                    log,
                    Some(serde_json::from_str::<Value>(&read(Path::new(
                        instructions,
                    ))?)?),
                ),
                _ => return Err(usage.into()),
            };
            print!(
                "{}",
                tick_table(
                    Path::new(dir),
                    &read(Path::new(log))?,
                    instructions.as_ref()
                )
            );
        }
        "rate" => {
            let file = rest.first().ok_or(usage)?;
            let rows = rate_rows(&json_lines(Path::new(file))?);
            print!("{}", rate_table(&rows));
            if let Some(svg) = flag("--svg") {
                let caption = rest
                    .iter()
                    .position(|a| a == "--caption")
                    .and_then(|i| rest.get(i + 1))
                    .cloned()
                    .unwrap_or_else(|| "rmd bench rate: rate against the wire limit".to_string());
                rate_plot(&rows, &svg, &caption)?;
            }
        }
        "criterion" => {
            let (dir, prefixes) = rest.split_first().ok_or(usage)?;
            print!(
                "{}",
                criterion_table(&criterion_means(Path::new(dir)), prefixes)
            );
        }
        "loop" => {
            let reports = rest
                .iter()
                .map(|p| Ok(serde_json::from_str(&read(Path::new(p))?)?))
                .collect::<Result<Vec<Value>, Error>>()?;
            print!("{}", loop_table(&reports));
        }
        "summary" => {
            let summary = Summary {
                tick_dir: flag("--tick").ok_or(usage)?,
                tick_log: flag("--tick-log")
                    .map(|p| read(&p))
                    .transpose()?
                    .unwrap_or_default(),
                jitter: flag("--jitter")
                    .map(|p| read(&p).and_then(|t| Ok(serde_json::from_str(&t)?)))
                    .transpose()?,
                rate: flag("--rate")
                    .map(|p| json_lines(&p))
                    .transpose()?
                    .map(|v| rate_rows(&v))
                    .unwrap_or_default(),
            };
            print!("{}", summary_table(&summary));
        }
        _ => return Err(usage.into()),
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::ExitCode::from(2)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rate_object(buses: u64, rate: f64, limit: f64) -> Value {
        serde_json::json!({
            "buses": buses,
            "wire_limit_hz": limit,
            "rate_hz": rate,
            "rate_of_wire_limit": rate / limit,
            "zero_miss_rate_hz": rate * 0.9,
            "zero_miss_of_wire_limit": rate * 0.9 / limit,
            "loop_added_us": {"p50": 1.5, "p99": 4.25},
            "trials": [
                {"sim_late_items": 2, "simulator_missed_slots": 0},
                {"sim_late_items": 1, "simulator_missed_slots": 4},
            ],
        })
    }

    #[test]
    fn the_rate_table_and_summary_come_from_the_json() {
        let rows = rate_rows(&[
            rate_object(1, 1200.0, 1225.0),
            rate_object(4, 1150.0, 1210.0),
        ]);
        assert_eq!(rows[0].sim_late, 3);
        assert_eq!(rows[0].sim_missed, 4);
        let table = rate_table(&rows);
        assert!(
            table.contains("| 1 | 1225.0 Hz | **1200.0 Hz** | **98.0%** | 1080.0 Hz | 88.2% | 1.50 / 4.25 us | 100.0% | 2 | 3 / 4 |"),
            "{table}"
        );
        assert!(
            table.contains("| 4 | 1210.0 Hz | **1150.0 Hz** | **95.0%** |"),
            "{table}"
        );
        assert!(table.contains("| 95.8% |"), "{table}");
        let summary = summary_table(&Summary {
            tick_dir: PathBuf::from("/nonexistent"),
            tick_log: "loop alone 1x4: 0 allocations in 10000 ticks (0 per tick)\n".to_string(),
            jitter: Some(serde_json::json!({
                "spin_us": 100.0,
                "cyclictest": {"p99": 20.0},
                "rmd_sleep": {"p99": 21.0, "p99_ratio": 1.05},
                "rmd_spin": {"p99": 1.0, "p99_ratio": 0.05},
            })),
            rate: rows,
        });
        assert!(
            summary.contains("21.00 us vs 20.00 us: **1.05x** (met)"),
            "{summary}"
        );
        assert!(
            summary.contains("1200.0 Hz = **98.0%** of 1225.0 Hz (met)"),
            "{summary}"
        );
        assert!(summary.contains("p99 **4.25 us** (met)"), "{summary}");
        assert!(summary.contains("**95.8%** (met)"), "{summary}");
        // No criterion output: shown as missing, not invented.
        assert!(
            summary.contains("| **- us**, 0 allocations in 10000 ticks |"),
            "{summary}"
        );
    }

    #[test]
    fn the_tick_table_puts_instructions_and_time_per_instruction_beside_the_means() {
        let dir = std::env::temp_dir().join(format!("bench-figures-tick-{}", std::process::id()));
        let d = dir.join("tick").join("loop alone 1x4").join("new");
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(
            d.join("estimates.json"),
            r#"{"mean":{"point_estimate":820.0}}"#,
        )
        .unwrap();
        let instructions: Value =
            serde_json::from_str(r#"{"ir_per_tick":{"1x4":4100.0,"4x4":12683.0,"8x4":24122.0}}"#)
                .unwrap();
        let table = tick_table(&dir, "", Some(&instructions));
        std::fs::remove_dir_all(&dir).unwrap();
        // 820 ns over 4100 instructions; 4x4 has no criterion mean, so no time per instruction.
        assert!(
            table.contains("| **0.82 us** | - | 4100 | 0.200 |"),
            "{table}"
        );
        assert!(table.contains("| **- us** | - | 12683 | - |"), "{table}");
        assert!(tick_table(&dir, "", None).contains("| - | - |"));
    }

    #[test]
    fn criterion_means_are_found_by_id_and_filtered_by_prefix() {
        let dir = std::env::temp_dir().join(format!("bench-figures-{}", std::process::id()));
        for (sub, id, ns) in [("a/x/new", "a/x", 35.8), ("b/new", "b", 1250.0)] {
            let d = dir.join(sub);
            std::fs::create_dir_all(&d).unwrap();
            std::fs::write(d.join("benchmark.json"), format!(r#"{{"full_id":"{id}"}}"#)).unwrap();
            std::fs::write(
                d.join("estimates.json"),
                format!(r#"{{"mean":{{"point_estimate":{ns}}}}}"#),
            )
            .unwrap();
        }
        let means = criterion_means(&dir);
        assert_eq!(
            means,
            [("a/x".to_string(), 0.0358), ("b".to_string(), 1.25)]
        );
        let table = criterion_table(&means, &["a/".to_string()]);
        assert!(table.contains("| a/x | 35.8 ns |"), "{table}");
        assert!(!table.contains("| b |"), "{table}");
        assert!(criterion_table(&means, &[]).contains("| b | 1.25 us |"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn allocations_are_read_from_the_tick_log() {
        let log = "loop+sim 1x4: 0 allocations in 10000 ticks (0 per tick)\nloop alone 4x4: 3 allocations in 10000 ticks (0.0003 per tick)\n";
        assert_eq!(allocations(log, "loop alone 4x4"), Some((3, 10000)));
        assert_eq!(allocations(log, "loop alone 1x4"), None);
    }

    #[test]
    fn the_loop_table_has_one_column_per_report() {
        let report = |buses: u64| {
            serde_json::json!({
                "ticks": 1000, "missed_ticks": 2, "deadline_misses": 1, "skipped_ticks": 1,
                "missing_replies": 0, "late_replies": 0,
                "wake_latency_us": {"p50": 0.1, "p99": 0.2, "p999": 1.5, "max": 80.0},
                "round_trip_us": {"p50": 790.0, "p99": 805.0, "max": 812.0},
                "controller_us": {"p50": 0.4, "p99": 2.0, "max": 40.0},
                "loop_added_us": {"p50": 1.0, "p99": 3.0, "max": 50.0},
                "realtime": "cpu pinning: applied",
                "bench": {"buses": buses, "motors_per_bus": 4, "tracking_rms_error_deg": 0.437, "tracking_max_error_deg": 0.575},
            })
        };
        let table = loop_table(&[report(1), report(4)]);
        assert!(
            table.starts_with("| | 1 bus(es) x 4 motors | 4 bus(es) x 4 motors |"),
            "{table}"
        );
        assert!(
            table.contains("| missed ticks / deadline misses / skipped | 2 / 1 / 1 | 2 / 1 / 1 |"),
            "{table}"
        );
        assert!(
            table.contains("| loop added p50 / p99 / max (us) | 1.0 / 3.0 / 50.0 |"),
            "{table}"
        );
    }
}

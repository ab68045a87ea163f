//! `rmd bench`: flags, output shape and the error contract. Real-time runs are short and only
//! their shape is checked (this is a shared, noisy machine: timing goals live in the benchmarks,
//! see docs/benchmarks.md); virtual-time runs are deterministic and checked exactly.

use assert_cmd::Command;
use serde_json::Value;

struct Run {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

fn rmd(args: &str) -> Run {
    let out = Command::cargo_bin("rmd")
        .unwrap()
        .args(args.split_whitespace())
        .output()
        .unwrap();
    Run {
        code: out.status.code(),
        stdout: String::from_utf8(out.stdout).unwrap(),
        stderr: String::from_utf8(out.stderr).unwrap(),
    }
}

/// Runs a command that must succeed and print one JSON object.
fn json(args: &str) -> Value {
    let run = rmd(args);
    assert_eq!(run.code, Some(0), "rmd {args}: {}", run.stderr);
    assert_eq!(run.stdout.lines().count(), 1, "one line: {}", run.stdout);
    serde_json::from_str(&run.stdout).unwrap_or_else(|e| panic!("{e}: {}", run.stdout))
}

/// Runs a real-time command that prints one JSON object: it may end in a fault on a loaded
/// machine (exit 1, e.g. a motor silent for 20 ticks while the simulator's thread waited for a
/// CPU), which a shape test accepts.
fn json_real_time(args: &str) -> Value {
    let run = rmd(args);
    assert!(
        matches!(run.code, Some(0 | 1)),
        "rmd {args}: {:?} {}",
        run.code,
        run.stderr
    );
    assert_eq!(run.stdout.lines().count(), 1, "one line: {}", run.stdout);
    serde_json::from_str(&run.stdout).unwrap_or_else(|e| panic!("{e}: {}", run.stdout))
}

/// Asserts a usage error: exit 2, nothing on stdout, one line on stderr containing `needle`.
fn usage_error(args: &str, needle: &str) {
    let run = rmd(args);
    assert_eq!(
        run.code,
        Some(2),
        "rmd {args}: {}{}",
        run.stdout,
        run.stderr
    );
    assert!(run.stdout.is_empty(), "rmd {args}: stdout {}", run.stdout);
    assert_eq!(run.stderr.lines().count(), 1, "rmd {args}: {}", run.stderr);
    assert!(
        run.stderr.contains(needle),
        "rmd {args}: `{needle}` not in {}",
        run.stderr
    );
}

fn assert_percentiles(v: &Value, key: &str) {
    let p = &v[key];
    for k in ["min", "p50", "p90", "p99", "p999", "max"] {
        assert!(p[k].is_number(), "{key}.{k} in {p}");
    }
    assert!(p["p50"].as_f64() <= p["p99"].as_f64(), "{key}: {p}");
}

#[test]
fn loop_in_virtual_time_reports_every_tick_and_tracks_the_targets() {
    let v = json("bench loop --virtual-time --seconds 1 --json");
    for key in [
        "ticks",
        "deadline_misses",
        "missing_replies",
        "late_replies",
        "telemetry_drops",
    ] {
        assert!(v[key].is_u64(), "{key} in {v}");
    }
    for key in [
        "wake_latency_us",
        "round_trip_us",
        "controller_us",
        "work_us",
    ] {
        assert_percentiles(&v, key);
    }
    assert_eq!(v["ticks"], 1000);
    assert_eq!(v["deadline_misses"], 0);
    assert_eq!(v["missing_replies"], 0);
    assert_eq!(v["late_replies"], 0);
    assert_eq!(v["telemetry_drops"], 0);
    assert_eq!(v["normal_stop"], true);
    // Virtual time: the timer is exact, and an exchange of 5 frames + 200 us turnaround takes
    // about 0.8 ms of simulated wire time.
    assert_eq!(v["wake_latency_us"]["max"], 0.0);
    let rtt = v["round_trip_us"]["p50"].as_f64().unwrap();
    assert!((700.0..900.0).contains(&rtt), "{rtt}");
    let bench = &v["bench"];
    assert_eq!(bench["motors_per_bus"], 4);
    assert_eq!(bench["buses"], 1);
    assert_eq!(bench["virtual_time"], true);
    // The PD controller follows its 20-degree sines within a degree once settled.
    let rms = bench["tracking_rms_error_deg"].as_f64().unwrap();
    assert!(rms > 0.0 && rms < 1.0, "{rms}");
}

#[test]
fn motors_count_per_bus() {
    let run = rmd("bench loop --virtual-time --motors 2 --buses 3 --seconds 0.6 --rate 500");
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(
        run.stdout
            .starts_with("rmd-rt loop report: 6 motor(s) on 3 bus(es) at 500 Hz"),
        "{}",
        run.stdout
    );
    assert!(run.stdout.contains("ticks 300 "), "{}", run.stdout);
    assert!(run.stdout.contains("(bus 2 motor 2):"), "{}", run.stdout);
    assert!(!run.stdout.contains("motor 3):"), "{}", run.stdout);
    assert!(run.stdout.contains("rms error"), "{}", run.stdout);
}

#[test]
fn loop_in_real_time_has_the_same_shape() {
    for (args, sim) in [
        (
            "bench loop --seconds 0.3 --spin-us 20 --cpu 0 --json",
            "thread",
        ),
        (
            "bench loop --seconds 0.2 --buses 2 --sim inline --json",
            "inline",
        ),
    ] {
        let v = json_real_time(args);
        for key in [
            "wake_latency_us",
            "round_trip_us",
            "controller_us",
            "work_us",
            "loop_added_us",
        ] {
            assert_percentiles(&v, key);
        }
        assert!(v["ticks"].as_u64().unwrap() > 0);
        assert!(v["missed_ticks"].is_u64());
        assert_eq!(v["bench"]["virtual_time"], false);
        assert_eq!(v["bench"]["sim"], sim);
        assert!(v["safe_stop"].is_object(), "{v}");
    }
    let v = json_real_time("bench loop --seconds 0.3 --spin-us 20 --cpu 0 --json");
    assert_eq!(v["bench"]["spin_us"], 20);
    assert_eq!(v["bench"]["cpu"], 0);
    // Pinned: the CPU latency request is on the real-time line (held, or why not).
    assert!(
        v["realtime"]
            .as_str()
            .unwrap()
            .contains("cpu_dma_latency: 0 us"),
        "{v}"
    );
}

#[test]
fn loop_rejects_bad_values() {
    usage_error("bench loop --motors 9", "--buses");
    usage_error("bench loop --motors 0", "1..=8");
    // Five motors per motor need 1350 us a tick: refused at 1 kHz, naming the highest rate.
    usage_error(
        "bench loop --motors 5",
        "The highest rate this bus can carry is 666 Hz",
    );
    usage_error("bench loop --buses 0", "1..=8");
    usage_error("bench loop --buses 9", "1..=8");
    usage_error("bench loop --rate 0", "--rate");
    usage_error("bench loop --rate abc", "--rate");
    usage_error("bench loop --rate 1e9", "shorter than the minimum");
    usage_error("bench loop --seconds 0", "--duration");
    usage_error("bench loop --seconds nan", "--duration");
    usage_error("bench loop --fifo 0", "1..=99");
    usage_error("bench loop --fifo 100", "1..=99");
    usage_error("bench loop --cpu 100000", "not available");
    usage_error("bench loop --spin-us x", "--spin-us");
    // Valid flags, impossible set-ups: the loop's own validation, naming the key.
    usage_error(
        "bench loop --virtual-time --rate 2000 --seconds 0.1",
        "cannot carry one exchange per tick",
    );
    usage_error(
        "bench loop --virtual-time --spin-us 1000 --seconds 0.1",
        "spin_margin_us",
    );
}

#[test]
fn jitter_json_has_the_stable_keys_and_a_whole_microsecond_histogram() {
    let v = json("bench jitter --seconds 0.2 --json");
    assert_eq!(v["ticks"], 200);
    assert!(v["deadline_misses"].is_u64());
    assert_percentiles(&v, "wake_latency_us");
    assert_eq!(v["wake_latency_us"]["count"], 200);
    let hist = v["histogram_us"].as_array().unwrap();
    let total: u64 = hist.iter().map(|b| b[1].as_u64().unwrap()).sum();
    assert_eq!(total, 200);
    // Buckets ascend, and the min falls in the first one (or, above 16 us, one higher: see
    // bench/histogram.rs).
    let ks: Vec<u64> = hist.iter().map(|b| b[0].as_u64().unwrap()).collect();
    assert!(ks.windows(2).all(|w| w[0] < w[1]), "{ks:?}");
    let min = v["wake_latency_us"]["min"].as_f64().unwrap().trunc() as u64;
    assert!(ks[0] == min || ks[0] == min + 1, "{ks:?} min {min}");

    let v = json("bench jitter --period-us 500 --seconds 0.1 --spin-us 50 --cpu 0 --json");
    assert_eq!(v["ticks"], 200);
    assert_eq!(v["period_us"], 500.0);
    assert_eq!(v["spin_us"], 50.0);
    assert_eq!(v["cpu"], 0);
    // Pinned: the CPU latency request is 0 us, held (or, without the device or the privilege,
    // failed with the reason on the real-time line).
    let realtime = v["realtime"].as_str().unwrap();
    assert!(realtime.contains("cpu_dma_latency: 0 us "), "{realtime}");
    assert_eq!(
        v["cpu_dma_latency_us"].as_u64() == Some(0),
        realtime.contains("0 us held"),
        "{realtime}"
    );
    let v = json("bench jitter --seconds 0.05 --cpu 0 --cpu-dma-latency off --json");
    assert!(v["cpu_dma_latency_us"].is_null());
    let realtime = v["realtime"].as_str().unwrap();
    assert!(
        realtime.contains("cpu_dma_latency: not requested"),
        "{realtime}"
    );
}

#[test]
fn jitter_prints_a_cyclictest_like_line() {
    let run = rmd("bench jitter --seconds 0.1 --period-us 2000");
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let first = run.stdout.lines().next().unwrap();
    assert!(first.starts_with("T: 0 ("), "{first}");
    for field in ["P:0", "I:2000", "C:", "Min:", "Avg:", "Max:"] {
        assert!(first.contains(field), "{field} in {first}");
    }
    assert!(first.contains("C:      50 "), "{first}");
    assert!(run.stdout.contains("p99.9"), "{}", run.stdout);
}

#[test]
fn jitter_rejects_bad_values() {
    usage_error("bench jitter --period-us 5", "shorter than the minimum");
    usage_error("bench jitter --period-us abc", "--period-us");
    usage_error(
        "bench jitter --period-us 1000 --spin-us 1000",
        "shorter than the period",
    );
    usage_error("bench jitter --seconds -1", "--duration");
    usage_error("bench jitter --fifo 120", "1..=99");
    usage_error("bench jitter --cpu 100000", "not available");
    usage_error("bench jitter --cpu-dma-latency -3", "--cpu-dma-latency");
}

#[test]
fn rate_search_in_virtual_time_finds_the_wire_limit() {
    // In virtual time the loop itself costs nothing: the highest rate, with or without a few
    // missed ticks, is the wire limit of the frames sent, to the search's resolution.
    let v = json("bench rate --virtual-time --seconds 0.5 --resolution-pct 0.5 --json");
    assert_eq!(v["buses"], 1);
    assert_eq!(v["miss_budget_pct"], 0.1);
    let rate = v["rate_hz"].as_f64().unwrap();
    let zero = v["zero_miss_rate_hz"].as_f64().unwrap();
    let limit = v["wire_limit_hz"].as_f64().unwrap();
    // An exchange of four motors at 1 Mbit/s: five frames of 111..135 bits + 200..220 us.
    let headline = v["trials"]
        .as_array()
        .unwrap()
        .iter()
        .rev()
        .find(|t| t["rate_hz"] == v["rate_hz"])
        .unwrap();
    let cycle = headline["wire_limit"]["max_cycle_us"].as_f64().unwrap();
    assert!((755.0..=895.0).contains(&cycle), "{cycle}");
    assert!((limit - 1e6 / cycle).abs() < 1e-6, "{limit} vs {cycle}");
    // At most the limit plus the last reply's intermission, which the loop need not wait for
    // (3 bit times); at least the limit less the resolution.
    for r in [rate, zero] {
        assert!(
            r <= 1e6 / (cycle - 3.0) + 1e-9,
            "{r} > the wire limit of {cycle} us"
        );
        assert!(r >= limit * (1.0 - 0.005), "{r} vs {limit}");
    }
    assert!(zero <= rate);
    let ratio = v["rate_of_wire_limit"].as_f64().unwrap();
    assert!((ratio - rate / limit).abs() < 1e-12, "{ratio}");
    // The loop costs no virtual time: it adds nothing after the last reply (the histogram's
    // lowest bucket is 1 ns).
    assert_eq!(v["loop_added_us"]["max"], 0.0);
    assert!(v["loop_added_us"]["p99"].as_f64().unwrap() <= 0.001);
    let trials = v["trials"].as_array().unwrap();
    assert!(trials.len() >= 3);
    for t in trials {
        assert_percentiles(t, "loop_added_us");
        let missed = t["missed_fraction"].as_f64().unwrap();
        assert_eq!(t["zero_misses"], missed == 0.0, "{t}");
        assert_eq!(t["within_budget"], missed <= 0.001, "{t}");
    }
    assert!(v["rate_passes"].as_u64().unwrap() >= 2, "confirmed: {v}");
}

#[test]
fn one_rate_trial_per_bus_count_passes_below_and_fails_above_the_wire_limit() {
    let v = json("bench rate --virtual-time --rate 1000 --seconds 0.3 --json");
    let t = &v["trials"][0];
    assert_eq!(t["zero_misses"], true);
    assert_eq!(t["ticks"], 300);
    assert_eq!(t["missed_ticks"], 0);
    assert_eq!(v["rate_hz"], 1000.0);
    assert_eq!(v["zero_miss_rate_hz"], 1000.0);

    // Several bus counts: one JSON object per line, in order. In virtual time the buses run in
    // parallel: the same limit as one.
    let run = rmd("bench rate --virtual-time --buses 1,2,4,8 --rate 1000 --seconds 0.2 --json");
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let lines: Vec<Value> = run
        .stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 4);
    for (v, buses) in lines.iter().zip([1, 2, 4, 8]) {
        assert_eq!(v["buses"], buses);
        assert_eq!(v["trials"][0]["buses"], buses);
        assert_eq!(v["trials"][0]["zero_misses"], true, "{v}");
        assert_eq!(v["rate_hz"], 1000.0, "{v}");
        assert_eq!(v["zero_miss_rate_hz"], 1000.0, "{v}");
        assert!(v["wire_limit_hz"].as_f64().unwrap() > 1000.0, "{v}");
        assert!(v["loop_added_us"]["p99"].is_number(), "{v}");
    }

    // 1400 Hz is a 714 us period: shorter than any 4-motor exchange at 1 Mbit/s.
    let run = rmd("bench rate --virtual-time --rate 1400 --seconds 0.3 --json");
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let v: Value = serde_json::from_str(&run.stdout).unwrap();
    let t = &v["trials"][0];
    assert_eq!(t["within_budget"], false);
    assert!(t["missed_fraction"].as_f64().unwrap() > 0.5, "{t}");
    assert!(v["rate_hz"].is_null());
    assert!(v["zero_miss_rate_hz"].is_null());
    assert!(v["loop_added_us"].is_null());
    // Why, and what to try.
    let why = v["why_no_rate"].as_array().unwrap();
    assert!(
        why[0].as_str().unwrap().contains("above the wire limit"),
        "{v}"
    );
    assert_eq!(v["what_to_try"][0]["flags"], "--rate 1000", "{v}");
}

/// A bus count that finds no rate says why and what to try, and the suggestion works as
/// printed (its flag replacing the one given).
#[test]
fn rate_says_why_nothing_passed_and_what_to_try() {
    let run = rmd("bench rate --virtual-time --rate 1400 --seconds 0.3");
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(
        run.stdout
            .contains("1 bus(es): no rate within the budget (0.1% of ticks missed) in 1 trial(s)"),
        "{}",
        run.stdout
    );
    assert!(
        run.stdout.contains(
            "1 bus(es): why: every rate tried is above the wire limit of its frames (1225.4 Hz)"
        ),
        "{}",
        run.stdout
    );
    let tried = run
        .stdout
        .lines()
        .find_map(|l| l.strip_prefix("1 bus(es): try: "))
        .unwrap_or_else(|| panic!("no suggestion in {}", run.stdout));
    let flags = tried.split(": ").next().unwrap();
    assert_eq!(flags, "--rate 1000");
    let v = json(&format!(
        "bench rate --virtual-time {flags} --seconds 0.3 --json"
    ));
    assert_eq!(v["rate_hz"], 1000.0, "{v}");
    assert_eq!(v["why_no_rate"].as_array().unwrap().len(), 0, "{v}");
}

/// While it searches, every trial is followed by what the trials so far found.
#[test]
fn rate_reports_what_it_found_so_far_after_each_trial() {
    let run = rmd("bench rate --virtual-time --seconds 0.2");
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let lines: Vec<&str> = run.stderr.lines().collect();
    assert!(
        lines[0].contains("a search runs about 10 to 20 trials"),
        "{}",
        run.stderr
    );
    let trials = lines.iter().filter(|l| l.starts_with("trial ")).count();
    assert!(trials >= 3, "{}", run.stderr);
    for (i, line) in lines.iter().enumerate() {
        if line.starts_with("trial ") {
            assert!(
                lines[i + 1].starts_with("  so far (1 bus(es), "),
                "{}",
                run.stderr
            );
        }
    }
    // The last: the rate found, within the budget and with zero misses, and above it the
    // lowest beyond (the wire limit is about 1225 Hz).
    let last = lines
        .iter()
        .rev()
        .find(|l| l.starts_with("  so far"))
        .unwrap();
    assert!(last.contains(&format!("{trials} trial(s)")), "{last}");
    assert!(last.contains("within 0.1% up to 122"), "{last}");
    assert!(last.contains("beyond it from 12"), "{last}");
    assert!(last.contains("zero misses up to 122"), "{last}");
}

#[test]
fn rate_in_real_time_has_the_same_shape_with_the_simulators_on_their_threads_or_inline() {
    for sim in ["thread", "inline"] {
        let v = json(&format!(
            "bench rate --rate 500 --seconds 0.2 --buses 2 --sim {sim} --json"
        ));
        assert_eq!(v["sim"], sim);
        let t = &v["trials"][0];
        for key in [
            "loop_added_us",
            "wake_latency_us",
            "round_trip_us",
            "work_us",
            "last_reply_after_start_us",
            "reply_to_controller_us",
        ] {
            assert_percentiles(t, key);
        }
        assert_eq!(t["expected_ticks"], 100);
        assert!(t["wire_limit_hz"].as_f64().unwrap() > 500.0, "{t}");
        assert!(t["wire_limit"]["exchanges"].as_u64().unwrap() > 0, "{t}");
    }
}

#[test]
fn rate_rejects_bad_values() {
    usage_error("bench rate --resolution-pct 0", "0.01..=50");
    usage_error("bench rate --miss-budget-pct 20", "0..=10");
    usage_error("bench rate --confirm 100", "at most");
    usage_error("bench rate --motors 9", "1..=8");
    usage_error("bench rate --buses 1,9", "1..=8");
    usage_error("bench rate --sim nowhere", "--sim");
    usage_error("bench rate --sim inline --virtual-time", "--virtual-time");
    usage_error("bench rate --rate -3", "--rate");
}

#[test]
fn run_flags_speak_the_examples_vocabulary_and_take_units() {
    // `--duration` with units, `--seconds` (a bare number of seconds) and `--rate-hz` name the
    // same settings as `--duration` and `--rate`: the same virtual-time run, tick for tick.
    let canonical = json("bench loop --virtual-time --duration 300ms --rate 500 --json");
    for args in [
        "bench loop --virtual-time --seconds 0.3 --rate-hz 500 --json",
        "bench loop --virtual-time --duration 0.3 --rate 500 --json",
    ] {
        let v = json(args);
        assert_eq!(v["ticks"], canonical["ticks"], "{args}");
        assert_eq!(v["ticks"], 150, "{args}");
    }
    assert_eq!(
        json("bench loop --virtual-time --duration 1m --rate 50 --json")["ticks"],
        3000
    );
    let trial = json("bench rate --virtual-time --rate-hz 1000 --duration 100ms --json");
    assert_eq!(trial["seconds_per_trial"], 0.1);
    assert_eq!(trial["trials"][0]["rate_hz"], 1000.0);
    // `--fifo-priority` is `--fifo`: the same checks.
    usage_error("bench jitter --fifo-priority 0", "1..=99");
    // Durations that are not one say so, and nothing panics.
    for (args, needle) in [
        ("bench loop --duration inf", "not a finite duration"),
        ("bench loop --duration NaN", "not a finite duration"),
        ("bench loop --duration -2s", "cannot be negative"),
        ("bench loop --duration 2days", "at most 1day"),
        ("bench loop --duration 1e300", "too long"),
        (
            "bench loop --duration 99999999999999999999999s",
            "not a duration",
        ),
        ("bench jitter --duration soon", "not a duration"),
        ("bench rate --duration 0ms", "above 0"),
    ] {
        usage_error(args, needle);
    }
}

/// `rmd bench loop --sim-firmware lk-v2.3x` refuses to start (exit 1, the firmware named) before
/// any torque frame is sent: the benchmark robot is described as v1.61.
#[test]
fn bench_loop_refuses_firmware_it_cannot_drive_before_any_torque() {
    for (firmware, named) in [("lk-v2.3x", "LK-TECH")] {
        let out = assert_cmd::Command::cargo_bin("rmd")
            .unwrap()
            .args([
                "bench",
                "loop",
                "--sim-firmware",
                firmware,
                "--virtual-time",
                "--seconds",
                "1",
                "--json",
            ])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{firmware}");
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let stop = report["stop_reason"].as_str().unwrap();
        assert!(stop.contains(named), "{stop}");
        assert_eq!(report["ticks"], 0);
        for motor in report["safe_stop"]["motors"].as_array().unwrap() {
            assert_eq!(motor["commanded"], false, "{motor}");
        }
    }
}

/// Stable: `rmd bench loop --sim-firmware myactuator-v3 [--motors N]` runs V3 motors on the
/// per-motor exchange; a rate beyond the wire budget exits non-zero before any frame, naming the
/// highest rate the layout can carry.
#[test]
fn bench_loop_runs_v3_motors_per_motor_and_refuses_a_rate_beyond_the_wire() {
    let v = json(
        "bench loop --sim-firmware myactuator-v3 --motors 3 --virtual-time --duration 1s --json",
    );
    assert_eq!(v["ticks"], 1000, "{v}");
    assert_eq!(v["missing_replies"], 0, "{v}");
    let motors = v["safe_stop"]["motors"].as_array().unwrap();
    assert_eq!(motors.len(), 3);
    for motor in motors {
        assert_eq!(motor["off_confirmed"], true, "{motor}");
    }
    let families: Vec<&str> = v["identified"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["family"].as_str().unwrap())
        .collect();
    assert_eq!(families, ["myactuator-v3"; 3], "{v}");
    let tracking = v["bench"]["tracking_max_error_deg"].as_f64().unwrap();
    assert!(tracking < 3.0, "{v}");
    // Four V3 motors need 1080 us a tick at worst: 833 Hz at most with the default deadline.
    let out = assert_cmd::Command::cargo_bin("rmd")
        .unwrap()
        .args([
            "bench",
            "loop",
            "--sim-firmware",
            "myactuator-v3",
            "--motors",
            "4",
        ])
        .args(["--virtual-time", "--duration", "1s", "--json"])
        .output()
        .unwrap();
    assert_ne!(out.status.code(), Some(0));
    assert!(out.stdout.is_empty(), "no report: nothing ran");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("highest rate this bus can carry is 833 Hz"),
        "{err}"
    );
}

/// Stable: `rmd bench loop|rate --sim-firmware myactuator-v3 --exchange motion` runs the V3
/// motors in motion mode (one 0x400 + id command each per tick); motion mode on v1.61 motors is
/// refused before anything runs.
#[test]
fn bench_loop_and_rate_run_v3_motors_in_motion_mode() {
    let v = json(
        "bench loop --sim-firmware myactuator-v3 --motors 3 --exchange motion --virtual-time \
         --duration 1s --json",
    );
    assert_eq!(v["ticks"], 1000, "{v}");
    assert_eq!(v["missing_replies"], 0, "{v}");
    assert_eq!(v["late_replies"], 0, "{v}");
    assert_eq!(v["bench"]["exchange"], "motion", "{v}");
    for motor in v["safe_stop"]["motors"].as_array().unwrap() {
        assert_eq!(motor["off_confirmed"], true, "{motor}");
    }
    // The same PD law, run in the motors with 16-bit position feedback.
    let tracking = v["bench"]["tracking_max_error_deg"].as_f64().unwrap();
    assert!(tracking < 3.0, "{v}");
    // The wire limit of a motion exchange of three motors: six 8-byte frames.
    let line = json(
        "bench rate --sim-firmware myactuator-v3 --motors 3 --exchange motion --virtual-time \
         --duration 500ms --json",
    );
    let limit = line["wire_limit_hz"].as_f64().unwrap();
    assert!((1000.0..1500.0).contains(&limit), "{line}");
    let out = assert_cmd::Command::cargo_bin("rmd")
        .unwrap()
        .args(["bench", "loop", "--motors", "2", "--exchange", "motion"])
        .args(["--virtual-time", "--duration", "1s", "--json"])
        .output()
        .unwrap();
    assert_ne!(out.status.code(), Some(0));
    assert!(out.stdout.is_empty(), "no report: nothing ran");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no motion mode"), "{err}");
}

/// `--exchange multi-torque --motors 8`: one 0x280 frame for ids 1..=4 and an 0xA1 request for
/// each of 5..=8 (13 frames an exchange instead of a per-motor bus's 16): a higher wire limit.
#[test]
fn eight_motors_on_a_0x280_frame_and_requests_beyond_it_beat_eight_per_motor() {
    let v = json(
        "bench loop --motors 8 --exchange multi-torque --rate 500 --virtual-time --duration 1s \
         --json",
    );
    assert_eq!(v["ticks"], 500, "{v}");
    assert_eq!(v["missing_replies"], 0, "{v}");
    assert_eq!(v["late_replies"], 0, "{v}");
    for motor in v["safe_stop"]["motors"].as_array().unwrap() {
        assert_eq!(motor["off_confirmed"], true, "{motor}");
    }
    let limit = |exchange: &str| {
        json(&format!(
            "bench rate --motors 8 --exchange {exchange} --virtual-time --duration 500ms --json"
        ))["wire_limit_hz"]
            .as_f64()
            .unwrap()
    };
    let (mixed, per_motor) = (limit("multi-torque"), limit("per-motor"));
    assert!(
        mixed > 1.15 * per_motor,
        "{mixed} Hz against {per_motor} Hz"
    );
}

#[test]
fn telemetry_cost_alternates_rounds_and_reports_what_every_sink_got() {
    let v = json("bench telemetry --motors 1 --rate 200 --duration 300ms --rounds 2 --json");
    let rounds = v["rounds"].as_array().unwrap();
    assert_eq!(rounds.len(), 4, "{v}");
    for (i, round) in rounds.iter().enumerate() {
        let on = i % 2 == 1;
        assert_eq!(round["sinks"], on, "off, on, off, on: {v}");
        assert_percentiles(round, "work_us");
        let ticks = round["ticks"].as_u64().unwrap();
        assert!(ticks > 0, "{round}");
        if !on {
            assert!(round["telemetry"].is_null(), "no sinks, no report: {round}");
            continue;
        }
        let sinks = round["telemetry"].as_array().unwrap();
        let names: Vec<&str> = sinks.iter().map(|s| s["name"].as_str().unwrap()).collect();
        assert_eq!(names.len(), 3, "{names:?}");
        assert!(names[0].starts_with("mcap ") && names[0].ends_with(".mcap"));
        assert!(names[1].starts_with("foxglove ws://127.0.0.1:"));
        assert!(names[2].starts_with("csv ") && names[2].ends_with(".csv"));
        for sink in sinks {
            // Every sample the loop published is accounted for, by every sink alike.
            let offered = ["written", "dropped", "failed"]
                .iter()
                .map(|k| sink[*k].as_u64().unwrap())
                .sum::<u64>();
            assert!(offered > 0 && offered <= ticks, "{sink} of {ticks} ticks");
            assert_eq!(sink["errors"], 0, "{sink}");
        }
        // The round's files are removed once it is over.
        let mcap = names[0].trim_start_matches("mcap ");
        assert!(!std::path::Path::new(mcap).exists(), "{mcap}");
    }
    // The ratio is of the medians of the rounds' p99s.
    let median_p99 = |on: bool| {
        let mut p99: Vec<f64> = rounds
            .iter()
            .filter(|r| r["sinks"] == on)
            .map(|r| r["work_us"]["p99"].as_f64().unwrap())
            .collect();
        p99.sort_by(f64::total_cmp);
        (p99[0] + p99[1]) / 2.0
    };
    let (off, on) = (median_p99(false), median_p99(true));
    assert_eq!(v["work_p99_off_us"].as_f64().unwrap(), off, "{v}");
    assert_eq!(v["work_p99_on_us"].as_f64().unwrap(), on, "{v}");
    assert!(
        (v["ratio"].as_f64().unwrap() - on / off).abs() < 1e-12,
        "{v}"
    );
}

/// Eight v1.61 motors on one bus are driven per motor (ids 5..=8 are beyond a 0x280 frame); their
/// requests and replies interleave on the wire, and the rate search still finds the wire limit
/// of those exchanges (about 491 Hz at 1 Mbit/s).
#[test]
fn eight_motors_on_one_bus_run_per_motor_at_their_wire_limit_in_virtual_time() {
    let v = json("bench loop --motors 8 --rate 400 --virtual-time --duration 1s --json");
    assert_eq!(v["ticks"], 400, "{v}");
    assert_eq!(v["missing_replies"], 0, "{v}");
    let off = v["safe_stop"]["motors"].as_array().unwrap();
    assert_eq!(off.len(), 8);
    assert!(off.iter().all(|m| m["off_confirmed"] == true), "{v}");
    let out = rmd("bench rate --motors 8 --virtual-time --duration 1s");
    assert_eq!(out.code, Some(0), "{}{}", out.stdout, out.stderr);
    let headline = out
        .stdout
        .lines()
        .find(|l| l.contains("with at most 0.1% of ticks missed ="))
        .unwrap_or_else(|| panic!("{}", out.stdout));
    // "... = 99.9% of the wire limit 491.0 Hz": a wire limit was found, and reached.
    let share: f64 = headline
        .split(" = ")
        .nth(1)
        .and_then(|rest| rest.split('%').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("{headline}"));
    assert!((95.0..=105.0).contains(&share), "{headline}");
    let limit: f64 = headline
        .split("wire limit ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|hz| hz.parse().ok())
        .unwrap_or_else(|| panic!("{headline}"));
    assert!((450.0..530.0).contains(&limit), "{headline}");
}

//! Every fault kind of the matrix, on one bus and on two, in virtual time (deterministic), judged
//! by the simulated firmware: every motor safe after the run, within the bound each test states
//! from the fault. A few kinds again in real time, as `rmd drill` runs by default, with bounds
//! wide enough for a loaded machine (the claims there are "safe, and in this order").

use core::time::Duration;

use rmd_drill::{Drill, DrillError, DrillFault, DrillSpec};
use rmd_rig::SimTime;

const AT_MS: u64 = 200;
const SECONDS_MS: u64 = 600;

fn fault(text: &str) -> DrillFault {
    text.parse().unwrap()
}

fn drill(text: &str, buses: u8, time: SimTime) -> Drill {
    rmd_drill::run(
        &DrillSpec::new(fault(text))
            .buses(buses)
            .at(Duration::from_millis(AT_MS))
            .seconds(Duration::from_millis(SECONDS_MS))
            .time(time),
    )
    .unwrap()
}

/// Runs `text` on 1 and 2 buses in virtual time; every motor safe within `bound_ms` of the
/// fault, the loop's report agreeing with the firmware, and the stop reason containing `stop`.
fn safe_within(text: &str, bound_ms: f64, stop: &str) -> Vec<Drill> {
    [1, 2]
        .into_iter()
        .map(|buses| {
            let d = drill(text, buses, SimTime::Virtual);
            let json = d.to_json();
            assert!(d.passed(), "{json}");
            assert_eq!(d.motors, 4 * usize::from(buses), "{json}");
            assert!(d.believed_off_but_energised.is_empty(), "{json}");
            let tts = d.time_to_safe_ms.expect("safe");
            assert!(
                tts <= bound_ms,
                "{text} on {buses} bus(es): {tts} ms > {bound_ms} ms"
            );
            assert!(d.stop_reason.contains(stop), "{}", d.stop_reason);
            d
        })
        .collect()
}

/// Kinds the loop rides through: it runs to its end and makes every motor safe then.
const TO_THE_END_MS: f64 = (SECONDS_MS - AT_MS) as f64 + 20.0;

#[test]
fn bus_off_waits_for_the_restart_then_turns_every_motor_off() {
    for d in safe_within("bus-off:50", 50.0 + 10.0, "bus-off") {
        assert!(d.time_to_safe_ms.unwrap() >= 50.0);
        assert_eq!(d.confirmed_off, d.motors);
    }
}

#[test]
fn a_transmit_stall_is_ridden_out_until_the_frames_go() {
    for d in safe_within("tx-stall:100", 100.0 + 20.0, "no fresh feedback") {
        assert!(d.time_to_safe_ms.unwrap() >= 100.0);
        assert_eq!(d.confirmed_off, d.motors);
    }
}

#[test]
fn a_hanging_controller_is_stopped_by_the_supervisor_at_the_stall_bound() {
    // The default stall bound is 50 ms at 1 kHz. The supervisor is a thread of its own that
    // reads the virtual clock while the hanging controller advances it (1 ms per 250 us of
    // sleep), so how far past the bound it acts follows how soon the OS runs it: about 2 ms on
    // a quiet machine, 14 ms seen with every core busy. The claim is "by the supervisor, at the
    // stall bound, safe": the bound leaves 100 ms for the OS, the latency is the benchmarks'.
    for d in safe_within(
        "controller-hang:3000",
        50.0 + 100.0,
        "did not complete within 50 ms",
    ) {
        // Not before the bound (counted from the last sign of life, up to a period before).
        assert!(d.time_to_safe_ms.unwrap() >= 50.0 - 1.0);
        assert_eq!(d.report.safe_stop.by, rmd_loop::SafeStopBy::Supervisor);
    }
}

#[test]
fn a_controller_panic_is_made_safe_within_a_few_periods() {
    for d in safe_within("controller-panic", 5.0, "controller panicked") {
        assert!(d.report.panic.is_some());
    }
}

#[test]
fn a_nan_command_is_a_fault_not_a_silent_zero() {
    for d in safe_within("nan-command", 5.0, "not a finite number") {
        assert!(matches!(
            d.report.stop_reason,
            rmd_loop::StopReason::Fault(rmd_loop::Fault::RejectedCommand { .. })
        ));
    }
}

#[test]
fn a_slow_controller_misses_deadlines_and_is_safe_at_the_end() {
    // 1.5 ms of work in a 1 ms period: every tick overruns, so the run's 600 ticks last longer.
    for d in safe_within("slow-controller:1500", 3.5 * TO_THE_END_MS, "") {
        assert!(d.report.stats.deadline_misses > 0, "{}", d.to_json());
    }
}

#[test]
fn a_silent_motor_stops_the_run_after_twenty_ticks_and_still_hears_motor_off() {
    for d in safe_within(
        "silent-motor:2",
        20.0 + 5.0,
        "motor 2 on bus 0) gave no fresh feedback",
    ) {
        // It obeyed motor-off but could not say so: the loop names it unconfirmed.
        assert_eq!(d.confirmed_off, d.motors - 1);
        let unconfirmed: Vec<_> = d
            .report
            .safe_stop
            .unconfirmed()
            .map(|m| (m.bus, m.motor.get()))
            .collect();
        assert_eq!(unconfirmed, [(0, 2)]);
    }
}

#[test]
fn lost_replies_are_counted_and_ridden_through() {
    for d in safe_within("drop:0.1", TO_THE_END_MS, "tick limit") {
        assert!(d.report.stats.missing_replies > 0, "{}", d.to_json());
    }
}

#[test]
fn late_replies_are_counted_late_and_their_backlog_stops_the_run() {
    safe_within("late:0.1,3", TO_THE_END_MS, "");
}

#[test]
fn corrupt_replies_never_leave_a_motor_energised() {
    safe_within("corrupt:0.1", TO_THE_END_MS, "");
}

#[test]
fn duplicate_replies_are_ridden_through() {
    safe_within("duplicate:0.1", TO_THE_END_MS, "tick limit");
}

#[test]
fn short_replies_are_ridden_through() {
    safe_within("wrong-dlc:0.1", TO_THE_END_MS, "tick limit");
}

#[test]
fn an_overheating_motor_stops_the_run_at_its_temperature_limit() {
    safe_within("over-temperature", 5.0, "at or above its limit");
}

#[test]
fn a_motor_losing_its_supply_stops_the_run_where_the_health_rotation_has_room() {
    // Three motors per bus at 1 kHz leave room for the health rotation: motor 1's
    // under-voltage flag (its status reply, within three ticks) stops the run, naming it, and
    // every motor is off by the firmware's ground truth.
    for buses in [1, 2] {
        let d = rmd_drill::run(
            &DrillSpec::new(fault("low-voltage"))
                .buses(buses)
                .motors(3)
                .at(Duration::from_millis(AT_MS))
                .seconds(Duration::from_millis(SECONDS_MS))
                .time(SimTime::Virtual),
        )
        .unwrap();
        let json = d.to_json();
        assert!(d.passed(), "{json}");
        assert!(
            d.stop_reason.contains("motor 1 on bus 0") && d.stop_reason.contains("under-voltage"),
            "{json}"
        );
        assert!(d.time_to_safe_ms.expect("safe") <= 10.0, "{json}");
        assert!(json.contains("\"health_rotation\":[true"), "{json}");
    }
    // Four motors per bus at 1 kHz have no room for it: the firmware's own protection turns
    // motor 1 off, the run rides to its end, and the report says why the flag went unseen.
    for d in safe_within("low-voltage", TO_THE_END_MS, "tick limit") {
        assert!(
            d.report.health_notes[0].contains("no room on the wire"),
            "{:?}",
            d.report.health_notes
        );
    }
}

#[test]
fn an_emergency_stop_is_acted_on_within_a_few_periods() {
    safe_within("estop", 5.0, "EMERGENCY STOP");
}

#[test]
fn a_stop_is_acted_on_within_a_few_periods() {
    safe_within("stop", 5.0, "stop requested");
}

#[test]
fn an_undescribed_motor_refuses_the_start_before_any_torque() {
    for d in safe_within("unknown-motor:3", 0.0, "motor 3 answers on bus 0") {
        // Nothing was ever commanded: no motor was energised at any time.
        assert_eq!(d.time_to_safe_ms, Some(0.0));
        assert_eq!(d.confirmed_off, 0);
        assert_eq!(d.report.stats.ticks, 0);
    }
}

#[test]
fn the_verdict_sees_motors_left_energised_when_a_bus_stays_off_too_long() {
    // Bus-off for 1.5 s, longer than the safe stop waits (safe_stop.bus_off_wait_ms = 1000):
    // bus 0's motors keep their last command, and the drill says so; bus 1 is safe.
    let d = rmd_drill::run(
        &DrillSpec::new(fault("bus-off:1500"))
            .buses(2)
            .at(Duration::from_millis(100))
            .seconds(Duration::from_millis(300))
            .time(SimTime::Virtual),
    )
    .unwrap();
    assert!(!d.passed());
    assert_eq!(d.motors_energised_after, 4, "{}", d.to_json());
    assert!(d.energised.iter().all(|m| m.bus == 0));
    assert_eq!(d.time_to_safe_ms, None);
    assert!(
        d.report
            .safe_stop
            .to_string()
            .contains("may still be energised")
    );
    assert!(d.believed_off_but_energised.is_empty());
}

#[test]
fn drills_run_in_real_time_too() {
    // The default mode of `rmd drill`. Bounds are wide: a loaded test machine stalls for tens
    // of milliseconds at times; what must hold is "every motor safe, and soon".
    for (text, bound_ms) in [
        ("controller-hang:3000", 1000.0),
        ("estop", 500.0),
        ("bus-off:50", 1000.0),
        ("controller-panic", 500.0),
    ] {
        let d = drill(text, 2, SimTime::Real);
        assert!(d.passed(), "{}", d.to_json());
        let tts = d.time_to_safe_ms.unwrap();
        assert!(tts <= bound_ms, "{text}: {tts} ms");
    }
}

#[test]
fn bad_drills_are_refused_with_what_to_change() {
    let err = |spec: DrillSpec| rmd_drill::run(&spec).unwrap_err().to_string();
    let stop = || DrillSpec::new(DrillFault::Stop).time(SimTime::Virtual);
    assert_eq!(
        err(stop().buses(0)),
        "--buses 0: a drill runs on 1 to 8 buses"
    );
    assert!(err(stop().motors(5)).starts_with("--motors 5: a drill runs 1 to 4 motors per bus"));
    assert!(err(stop().seconds(Duration::ZERO)).starts_with("--seconds"));
    assert_eq!(
        err(stop().at(Duration::from_secs(3))),
        "--at 3 s is not before the end of the run (--seconds 2 s)"
    );
    assert_eq!(
        err(DrillSpec::new(fault("silent-motor:4")).motors(2)),
        "silent-motor:4: bus 0 has motors 1..=2; name one of them (or raise --motors)"
    );
    assert!(matches!(
        rmd_drill::run(&DrillSpec::new(fault("unknown-motor:1")).motors(1)),
        Err(DrillError::NothingDescribed { .. })
    ));
}

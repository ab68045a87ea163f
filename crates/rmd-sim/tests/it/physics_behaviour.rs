//! Physics as a bus client sees it, with the numbers worked out by hand.

use crate::common;

use common::*;
use rmd_bus::{CanBus, Clock, Timestamp};
use rmd_protocol::{
    Accel, AngleControl, Dialect, IqControl, MaxSpeed, Request, SingleTurnAngle, SpeedControl,
    SpinDirection,
};
use rmd_sim::{GravityLink, SimConfig, SimMotors};

#[test]
fn constant_torque_gives_the_expected_acceleration() {
    let mut config = SimConfig::with_motors(1);
    config.motors[0].motor.viscous_friction_nm_per_rad_s = 0.0;
    let (clock, mut bus) = sim_bus(config);
    let t0 = clock.now();
    // iqControl 250 = 4.0 A. Motor-side acceleration once the current has settled (0.2 ms time
    // constant): a = (Kt i - tau_c) / J = (2.09 / 9 x 4.0 - 0.04) / 2.6e-4
    //   = (0.928889 - 0.04) / 2.6e-4 = 3418.80 rad/s² = 195 883 dps/s.
    // Between two status reads 10 ms apart the speed grows by 1958.8 dps.
    ask(
        &mut bus,
        1,
        Request::Torque {
            iq_control: IqControl::new(250).unwrap().into(),
        },
    );
    wait_until(&bus, t0 + ms(10));
    let s1 = ask(&mut bus, 1, Request::ReadStatus2).status2().unwrap();
    wait_until(&bus, t0 + ms(20));
    let s2 = ask(&mut bus, 1, Request::ReadStatus2).status2().unwrap();
    let gained = s2.speed.dps() - s1.speed.dps();
    assert!(
        (gained - 1958.8).abs() <= 1.0,
        "gained {gained} dps in 10 ms"
    );
    // The reply current is the commanded 4.0 A on the 33/2048 scale: 248.2 -> 248.
    assert_eq!(s2.iq.raw(), 248);
}

#[test]
fn a_speed_step_settles_at_the_target_without_exceeding_max_acceleration() {
    // For several limits (0x34), a step to 1800 dps, a reversal to -1800 dps and a stop.
    // Sampled every substep (50 us), the acceleration never exceeds the limit (the firmware
    // ramps its reference at the limit, and the loop follows without overshooting it, even
    // across the breakaway from stiction and the reversal of dry friction), the speed never
    // overshoots the target, and settles within half a dps.
    for limit in [1_000i32, 20_000, 36_000] {
        let config = SimConfig::with_motors(1);
        let mut motors = SimMotors::new(&config, Timestamp::ZERO).unwrap();
        let m1 = id(1);
        let mut t = Timestamp::from_nanos(1_000_000);
        let accel = Request::WriteAccelRam {
            accel: Accel::new(limit.into()).unwrap(),
        };
        assert_eq!(
            motors
                .handle(&Dialect::V161.encode(m1, &accel).unwrap(), t)
                .count(),
            1
        );
        let mut last = 0.0;
        for (from, to) in [(0.0, 1800.0), (1800.0, -1800.0), (-1800.0, 0.0)] {
            let step = Request::Speed {
                speed_control: SpeedControl::from_dps(to).unwrap(),
                max_torque: rmd_protocol::MaxTorquePercent::NONE,
            };
            assert_eq!(
                motors
                    .handle(&Dialect::V161.encode(m1, &step).unwrap(), t)
                    .count(),
                1
            );
            // The ramp takes |to - from| / limit; then 0.3 s to settle.
            let ramp_s = f64::abs(to - from) / f64::from(limit);
            let steps = ((ramp_s + 0.3) / 50e-6) as usize;
            let (lo, hi) = (f64::min(from, to), f64::max(from, to));
            for _ in 0..steps {
                t += us(50);
                let speed = motors.snapshot_at(m1, t).unwrap().motor_speed_dps;
                let accel = (speed - last) / 50e-6;
                assert!(
                    accel.abs() <= f64::from(limit),
                    "limit {limit}: {accel} dps/s at {speed} dps"
                );
                assert!(
                    speed >= lo - 0.5 && speed <= hi + 0.5,
                    "limit {limit}: {speed} dps"
                );
                last = speed;
            }
            assert!(
                (last - to).abs() < 0.5,
                "limit {limit}: settled at {last}, not {to}"
            );
        }
    }
}

/// Drives a single-turn position command and checks the motion goes the commanded way.
fn single_turn_move(
    start_output_deg: f64,
    direction: SpinDirection,
    target_deg: f64,
    expected_travel_deg: f64,
) {
    let mut config = SimConfig::with_motors(1);
    config.motors[0].initial_output_angle_deg = start_output_deg;
    let mut motors = SimMotors::new(&config, Timestamp::ZERO).unwrap();
    let m1 = id(1);
    let mut t = Timestamp::from_nanos(1_000_000);
    let start = motors.snapshot_at(m1, t).unwrap().motor_angle_deg;
    let request = Request::Position4 {
        spin_direction: direction,
        max_speed: MaxSpeed::new(720).unwrap(),
        angle_control: SingleTurnAngle::from_degrees(target_deg).unwrap(),
    };
    assert_eq!(
        motors
            .handle(&Dialect::V161.encode(m1, &request).unwrap(), t)
            .count(),
        1
    );
    let sign = expected_travel_deg.signum();
    let mut previous = start;
    let mut arrived = false;
    for _ in 0..3_000 {
        t += ms(1);
        let angle = motors.snapshot_at(m1, t).unwrap().motor_angle_deg;
        if !arrived {
            // Until it first gets within 0.1° of the target it only moves the commanded way.
            assert!(
                (angle - previous) * sign >= 0.0,
                "moved back: {previous} -> {angle}"
            );
            arrived = ((angle - start) - expected_travel_deg).abs() < 0.1;
        }
        previous = angle;
    }
    assert!(arrived);
    let travel = previous - start;
    // Settled within two encoder counts (0.044°).
    assert!(
        (travel - expected_travel_deg).abs() < 0.045,
        "travelled {travel}"
    );
}

#[test]
fn position_mode_3_goes_the_commanded_direction() {
    // From 0° (motor side): clockwise to 90° is +90°, counterclockwise is -270°.
    single_turn_move(0.0, SpinDirection::Clockwise, 90.0, 90.0);
    single_turn_move(0.0, SpinDirection::CounterClockwise, 90.0, -270.0);
    // From 300° (output 300/9 °): clockwise to 90° is +150°, counterclockwise -210°.
    single_turn_move(300.0 / 9.0, SpinDirection::Clockwise, 90.0, 150.0);
    single_turn_move(300.0 / 9.0, SpinDirection::CounterClockwise, 90.0, -210.0);
}

fn leg(mass_kg: f64) -> SimConfig {
    let mut config = SimConfig::with_motors(1);
    config.motors[0].load.gravity = Some(GravityLink {
        mass_kg,
        length_m: 0.3,
        angle_offset_deg: 90.0,
    });
    config
}

#[test]
fn gravity_makes_an_unpowered_link_fall() {
    // 1 kg at 0.3 m, horizontal at output angle 0. At the motor: gravity 2.941995 / 9 =
    // 0.326888 N·m, minus 0.04 N·m of dry friction: 0.286888 N·m on J = 2.6e-4 + 0.09 / 81 =
    // 1.371111e-3 kg·m²: -209.23 rad/s². In 100 ms: a t² / 2 = 1.0462 rad = 59.94° at the
    // motor (a little less: the sine shrinks and viscous friction grows; 5 % allowed).
    let (clock, mut bus) = sim_bus(leg(1.0));
    let t0 = clock.now();
    let a0 = angle_deg(&mut bus, 1);
    wait_until(&bus, t0 + ms(100));
    let a1 = angle_deg(&mut bus, 1);
    let fallen = a0 - a1;
    assert!((fallen - 59.94).abs() < 59.94 * 0.05, "fell {fallen}°");
    // It keeps falling and swings through the bottom (no damping beyond friction).
    wait_until(&bus, t0 + ms(400));
    assert!(angle_deg(&mut bus, 1) < a1);
}

#[test]
fn stiction_holds_a_light_link_and_position_mode_holds_a_heavy_one() {
    // 0.1 kg: 0.0327 N·m at the motor, below the 0.04 N·m breakaway torque: it stays.
    let (clock, mut bus) = sim_bus(leg(0.1));
    let t0 = clock.now();
    let a0 = angle_deg(&mut bus, 1);
    wait_until(&bus, t0 + ms(500));
    assert_eq!(angle_deg(&mut bus, 1), a0);

    // 1 kg held at 0 in position mode: the speed loop's integral carries the 0.326888 N·m of
    // gravity (1.408 A), give or take what dry friction (0.04 N·m = 0.172 A) holds once the
    // rotor is at rest; the link stays within a few counts.
    let (clock, mut bus) = sim_bus(leg(1.0));
    let t0 = clock.now();
    ask(
        &mut bus,
        1,
        Request::Position1 {
            angle_control: AngleControl::new(0).unwrap(),
        },
    );
    wait_until(&bus, t0 + ms(1_000));
    let status = ask(&mut bus, 1, Request::ReadStatus2).status2().unwrap();
    let held = status.iq.amps();
    assert!(
        (held - 1.408).abs() <= 0.172 + 0.02,
        "holding current {held}"
    );
    assert!(angle_deg(&mut bus, 1).abs() < 0.1);
}

#[test]
fn i2r_heating_trips_over_temperature_and_a_clear_waits_for_cooling() {
    // A stuck rotor at 30 A: R i² = 0.8 x 900 = 720 W into 300 J/K: about 2.4 K/s at first,
    // so 80 °C is reached after ~25 s (the losses to ambient slow it a little).
    let mut config = SimConfig::with_motors(1);
    config.motors[0].motor.coulomb_friction_nm = 1_000.0;
    let (clock, mut bus) = sim_bus(config);
    let t0 = clock.now();
    ask(
        &mut bus,
        1,
        Request::Torque {
            iq_control: IqControl::from_amps(30.0).unwrap().into(),
        },
    );
    wait_until(&bus, t0 + ms(20_000));
    let s = v161_status1(ask(&mut bus, 1, Request::ReadStatus1));
    assert!(!s.error_state.over_temperature() && s.temperature.celsius() < 80.0);
    wait_until(&bus, t0 + ms(40_000));
    let s = v161_status1(ask(&mut bus, 1, Request::ReadStatus1));
    assert!(s.error_state.over_temperature(), "{s:?}");
    // The trip turned the motor off: no more current, so it cools (10 min time constant).
    let s2 = ask(&mut bus, 1, Request::ReadStatus2).status2().unwrap();
    assert_eq!(s2.iq.raw(), 0);
    // A clear does nothing until the winding is back below 80 - 5 °C: from 80 °C that takes
    // 600 s x ln(55 / 50) = 57 s. Then it clears.
    let mut refused = 0;
    let mut cleared = false;
    for second in 0..120 {
        wait_until(&bus, t0 + ms(40_000 + 1_000 * second));
        let before = bus.snapshot(id(1)).unwrap().temperature_c;
        let s = v161_status1(ask(&mut bus, 1, Request::ClearError));
        if before >= 75.0 {
            assert!(s.error_state.over_temperature());
            refused += 1;
        } else {
            assert!(!s.error_state.over_temperature());
            cleared = true;
            break;
        }
    }
    assert!(refused > 30 && cleared, "refused {refused} times");
}

#[test]
fn the_supply_sags_under_current() {
    // Stuck rotor at 32 A: P = R i² = 0.8 x 1024 = 819.2 W, supply current 819.2 / 48 =
    // 17.07 A, sag 0.05 x 17.07 = 0.853 V: 47.1 V (471 in 0.1 V).
    let mut config = SimConfig::with_motors(1);
    config.motors[0].motor.coulomb_friction_nm = 1_000.0;
    let (clock, mut bus) = sim_bus(config);
    let t0 = clock.now();
    let idle = v161_status1(ask(&mut bus, 1, Request::ReadStatus1));
    assert_eq!(idle.voltage.raw(), 480);
    ask(
        &mut bus,
        1,
        Request::Torque {
            iq_control: IqControl::new(2000).unwrap().into(),
        },
    );
    wait_until(&bus, t0 + ms(10));
    let loaded = v161_status1(ask(&mut bus, 1, Request::ReadStatus1));
    assert_eq!(loaded.voltage.raw(), 471);
    bus.send(&Dialect::V161.encode(id(1), &Request::MotorOff).unwrap())
        .unwrap();
}

//! From what a motor reports (single-turn encoder, motor-side speed and current) to what a
//! controller wants (continuous joint angle and velocity, torque).
//!
//! The 0xA1 reply carries the encoder position within one motor turn. The loop unwraps it into a
//! continuous multi-turn motor angle: between two readings the motor moved by the encoder
//! difference plus a whole number of turns, and the number of turns is the one closest to what
//! the reported speed predicts over the elapsed time. With one reading per tick that is the usual
//! "less than half a turn per tick" rule; after missing replies the speed keeps the count right.
//!
//! The joint angle is `direction * motor_angle / gear_ratio - zero_offset_deg`, continuous from
//! the first reading (which lies within the first motor turn: a geared joint must be homed).

use core::time::Duration;

use rmd_protocol::EncoderWidth;

use crate::robot::{JointSpec, Mounting};

/// Beyond this magnitude every `f64` is an integer (2^52).
const ALL_INTEGERS: f64 = 4_503_599_627_370_496.0;

/// The integer nearest to `x` clamped into `min..=max`, halves away from zero; NaN gives 0.
/// `min..=max` lies within +-2^52 (where every `f64` step is at most 1, so the result is exact).
/// Inline arithmetic: without SSE4.1 (the x86-64 baseline) `f64::round` is a library call.
#[inline]
pub(crate) fn nearest_integer_within(x: f64, min: f64, max: f64) -> i64 {
    debug_assert!(-ALL_INTEGERS <= min && min <= max && max <= ALL_INTEGERS);
    // Adding the largest double below one half, with x's sign, then truncating, rounds halves
    // away from zero and nothing else: at a fraction of exactly one half the sum is a tie that
    // rounds to the even neighbour, the next integer; below one half it stays below the next
    // integer. Exact within +-2^52 (where the spacing of doubles is at most 1). `as` gives 0 for
    // NaN (which `clamp` passes through).
    let x = x.clamp(min, max);
    (x + BELOW_HALF.copysign(x)) as i64
}

/// The largest `f64` below 0.5.
const BELOW_HALF: f64 = 0.499_999_999_999_999_94;

/// An hour in nanoseconds.
const HOUR_NS: u64 = 3_600_000_000_000;

/// Unwraps single-turn encoder readings into a continuous angle.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct EncoderUnwrapper {
    counts_per_turn: i64,
    /// Counts per degree per nanosecond at 1 deg/s: `counts_per_turn / 360 / 1e9`.
    counts_per_dps_ns: f64,
    /// `360 / counts_per_turn` (exact).
    degrees_per_count: f64,
    last: Option<u16>,
    /// Accumulated counts since the first reading, plus the first reading.
    counts: i64,
}

impl EncoderUnwrapper {
    /// An unwrapper for encoders of `width` (values above 16 bits are reported in the u16 field
    /// modulo 65536, so the turn is at most 65536 counts).
    pub fn new(width: EncoderWidth) -> Self {
        let counts_per_turn = 1i64 << width.bits().min(16);
        let n = counts_per_turn as f64;
        Self {
            counts_per_turn,
            counts_per_dps_ns: n / 360.0 / 1e9,
            degrees_per_count: 360.0 / n,
            last: None,
            counts: 0,
        }
    }

    /// Counts in one motor turn as reported in the frame.
    pub fn counts_per_turn(&self) -> i64 {
        self.counts_per_turn
    }

    /// Whether `encoder` is a possible reading.
    pub fn in_range(&self, encoder: u16) -> bool {
        i64::from(encoder) < self.counts_per_turn
    }

    /// Feeds one reading taken `elapsed` after the previous one while the motor turned at
    /// `speed_dps` (motor side); returns the continuous motor angle in degrees.
    pub fn update(&mut self, encoder: u16, speed_dps: f64, elapsed: Duration) -> f64 {
        self.update_ns(
            encoder,
            speed_dps,
            u64::try_from(elapsed.as_nanos()).unwrap_or(u64::MAX),
        )
    }

    /// [`update`](Self::update) with the time since the previous reading in nanoseconds.
    #[inline]
    pub fn update_ns(&mut self, encoder: u16, speed_dps: f64, elapsed_ns: u64) -> f64 {
        let n = self.counts_per_turn;
        // A turn is a power of two of counts: masks are the remainders, without dividing.
        let mask = n - 1;
        let reading = i64::from(encoder) & mask;
        match self.last {
            None => self.counts = reading,
            Some(last) => {
                let raw = (reading - i64::from(last)) & mask; // rem_euclid: 0..n
                // (An hour between readings is as good as forever: the count is then a guess.)
                let elapsed_ns = elapsed_ns.min(HOUR_NS) as i64 as f64;
                let expected = speed_dps * elapsed_ns * self.counts_per_dps_ns;
                // The prediction in whole counts (toward zero; NaN and infinities predict no
                // motion; beyond +-2^52 counts it is a guess anyway, and nothing below
                // overflows).
                let e = if expected.is_finite() {
                    expected.clamp(-ALL_INTEGERS, ALL_INTEGERS) as i64
                } else {
                    0
                };
                // The count congruent to raw (mod n) closest to the prediction: the one in
                // e - n/2 .. e + n/2.
                let half = n / 2;
                let delta = e + ((raw - e + half) & mask) - half;
                self.counts = self.counts.saturating_add(delta);
            }
        }
        self.last = Some(encoder);
        self.degrees()
    }

    /// The continuous motor angle in degrees (0 before the first reading).
    pub fn degrees(&self) -> f64 {
        self.counts as f64 * self.degrees_per_count
    }
}

/// The fixed mapping between one motor and its joint.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct JointMap {
    sign: f64,
    gear_ratio: f64,
    /// `sign / gear_ratio`: joint degrees per motor degree (a multiplication per reply, not a
    /// division).
    joint_per_motor: f64,
    zero_offset_deg: f64,
    /// The torque constant, 0.0 when unknown. Kept as a plain `f64` beside `has_torque_constant`
    /// rather than an `Option<f64>`: the optimiser computes `sign * amps * kt` without a branch
    /// and discards it when the constant is absent, and the payload of a `None` is whatever bits
    /// were there (a stale pointer reads as a subnormal double, which costs a microcode assist of
    /// ~100+ cycles per multiply: measured 3x slower ticks, see docs/benchmarks.md).
    torque_constant: f64,
    has_torque_constant: bool,
}

impl JointMap {
    /// The mapping of a joint of the robot description.
    pub fn from_spec(joint: &JointSpec) -> Self {
        Self {
            sign: joint.direction.sign(),
            gear_ratio: joint.gear_ratio,
            joint_per_motor: joint.direction.sign() / joint.gear_ratio,
            zero_offset_deg: joint.zero_offset_deg,
            torque_constant: joint.torque_constant_nm_per_amp.unwrap_or(0.0),
            has_torque_constant: joint.torque_constant_nm_per_amp.is_some(),
        }
    }

    /// Whether the torque constant is known (torque commands and feedback in N*m work).
    pub fn has_torque_constant(&self) -> bool {
        self.has_torque_constant
    }

    /// Joint angle (degrees) from the continuous motor angle.
    pub fn joint_angle_deg(&self, motor_deg: f64) -> f64 {
        motor_deg * self.joint_per_motor - self.zero_offset_deg
    }

    /// The continuous motor angle (degrees) at which the joint is at `joint_deg`: the inverse of
    /// [`joint_angle_deg`](Self::joint_angle_deg).
    pub fn motor_angle_deg(&self, joint_deg: f64) -> f64 {
        self.sign * (joint_deg + self.zero_offset_deg) * self.gear_ratio
    }

    /// Motor turns per joint turn.
    pub fn gear_ratio(&self) -> f64 {
        self.gear_ratio
    }

    /// Joint velocity (deg/s) from the motor speed.
    pub fn joint_velocity_dps(&self, motor_dps: f64) -> f64 {
        motor_dps * self.joint_per_motor
    }

    /// Joint torque (N*m) from the motor's torque current, if the torque constant is known.
    pub fn joint_torque_nm(&self, motor_amps: f64) -> Option<f64> {
        self.has_torque_constant
            .then_some(self.sign * motor_amps * self.torque_constant)
    }

    /// Motor current (amperes, motor sign) for a joint-side current (joint sign).
    pub fn motor_amps(&self, joint_amps: f64) -> f64 {
        self.sign * joint_amps
    }

    /// Motor current (amperes, motor sign) for a joint torque, if the torque constant is known.
    pub fn motor_amps_for_torque(&self, joint_nm: f64) -> Option<f64> {
        self.has_torque_constant
            .then(|| self.sign * joint_nm / self.torque_constant)
    }
}

/// The joint angles (degrees, `[low, high)`) in which a geared joint must be at power-up for the
/// loop to read its angle right: one motor turn of the single-turn encoder, starting where the
/// encoder reads zero, `-zero_offset_deg` (for a reversed joint the window extends below it).
/// See docs/getting-started.md, "Homing a geared joint".
///
/// ```
/// use rmd_loop::mapping::power_up_window;
/// use rmd_loop::robot::{BusConfig, Mounting, MotorConfig, Robot, RobotConfig};
/// let hip = MotorConfig::new(2).gear_ratio(9.0).zero_offset_deg(-30.0);
/// let reversed = MotorConfig::new(3).gear_ratio(9.0).zero_offset_deg(-30.0).direction(Mounting::Reversed);
/// let robot = Robot::try_from(RobotConfig::new(100.0).with_bus(BusConfig::new("can0")
///     .with_motor(hip)
///     .with_motor(reversed)))?;
/// assert_eq!(power_up_window(&robot.joints()[0]), (30.0, 70.0));
/// assert_eq!(power_up_window(&robot.joints()[1]), (-10.0, 30.0));
/// # Ok::<(), rmd_loop::robot::RobotError>(())
/// ```
pub fn power_up_window(joint: &JointSpec) -> (f64, f64) {
    let width = 360.0 / joint.gear_ratio;
    let start = -joint.zero_offset_deg;
    match joint.direction {
        Mounting::Normal => (start, start + width),
        Mounting::Reversed => (start - width, start),
    }
}

/// The `zero_offset_deg` that centres a joint's [`power_up_window`] on `joint_deg`: the joint
/// then reads its true angle when it powers up anywhere within `180 / gear_ratio` degrees of
/// `joint_deg`.
///
/// That is all a simulated motor matching the description needs (the rig mounts its encoder to
/// agree with any offset). On a real motor the offset also decides where joint zero is: read the
/// encoder (e.g. `rmd status ID`) with the joint at a known angle and compute the offset from
/// that, as docs/getting-started.md shows.
///
/// ```
/// use rmd_loop::mapping::centred_zero_offset_deg;
/// use rmd_loop::robot::Mounting;
/// // A 1:9 joint powering up around 0 degrees: window -20..20.
/// assert_eq!(centred_zero_offset_deg(9.0, Mounting::Normal, 0.0), 20.0);
/// ```
pub fn centred_zero_offset_deg(gear_ratio: f64, direction: Mounting, joint_deg: f64) -> f64 {
    let half = 180.0 / gear_ratio;
    match direction {
        Mounting::Normal => -(joint_deg - half),
        Mounting::Reversed => -(joint_deg + half),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::{BusConfig, MotorConfig, Robot, RobotConfig};
    use proptest::prelude::*;

    fn map(motor: MotorConfig) -> JointMap {
        let robot = Robot::try_from(
            RobotConfig::new(100.0).with_bus(BusConfig::new("can0").with_motor(motor)),
        )
        .unwrap();
        JointMap::from_spec(&robot.joints()[0])
    }

    fn w14() -> EncoderUnwrapper {
        EncoderUnwrapper::new(EncoderWidth::new(14).unwrap())
    }

    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn nearest_integer_within_rounds_halves_away_from_zero() {
        for (x, n) in [
            (0.5, 1),
            (-0.5, -1),
            (1.4999, 1),
            (-1.5, -2),
            (2.5, 3),
            (0.49999999999999994, 0),
            (-0.49999999999999994, 0),
            (0.0, 0),
            (-0.0, 0),
            (1e300, 1 << 52),
            (-1e300, -(1 << 52)),
            (f64::NAN, 0),
            (4503599627370495.0, 4503599627370495),
            (4503599627370495.5, 4503599627370496),
            (2251799813685248.5, 2251799813685249),
            (2251799813685249.5, 2251799813685250),
            (-2251799813685249.5, -2251799813685250),
            (1.5000000000000002, 2),
            (2.4999999999999996, 2),
            (-2.4999999999999996, -2),
        ] {
            assert_eq!(
                nearest_integer_within(x, -ALL_INTEGERS, ALL_INTEGERS),
                n,
                "{x}"
            );
        }
        for i in -1000..1000 {
            let x = f64::from(i) * 0.37;
            assert_eq!(
                nearest_integer_within(x, -ALL_INTEGERS, ALL_INTEGERS),
                x.round() as i64,
                "{x}"
            );
            let clamped = x.clamp(-100.0, 150.0);
            assert_eq!(
                nearest_integer_within(x, -100.0, 150.0),
                clamped.round() as i64,
                "{x}"
            );
        }
    }

    #[test]
    fn wraps_forward_and_backward_across_zero() {
        let mut u = w14();
        assert_eq!(u.update(16_000, 0.0, MS), 16_000.0 * 360.0 / 16_384.0);
        // 16000 -> 200 going forward is +584 counts, not -15800.
        let a = u.update(200, 100.0, MS);
        assert!((a - (16_584.0 * 360.0 / 16_384.0)).abs() < 1e-9);
        // And back.
        let b = u.update(16_000, -100.0, MS);
        assert!((b - 16_000.0 * 360.0 / 16_384.0).abs() < 1e-9);
    }

    #[test]
    fn speed_disambiguates_after_a_long_gap() {
        // 3.5 turns in 10 ms at 126000 deg/s: the encoder alone would say half a turn.
        let mut u = w14();
        u.update(0, 0.0, MS);
        let a = u.update(8_192, 126_000.0, Duration::from_millis(10));
        assert!((a - 3.5 * 360.0).abs() < 1e-9, "{a}");
        // And 3.5 turns back to encoder 0: the encoder alone would say half a turn forward.
        let b = u.update(0, -126_000.0, Duration::from_millis(10));
        assert!(b.abs() < 1e-9, "{b}");
    }

    #[test]
    fn joint_mapping_applies_gear_direction_and_offset() {
        let motor = MotorConfig::new(1)
            .gear_ratio(6.0)
            .direction(Mounting::Reversed)
            .zero_offset_deg(10.0)
            .torque_constant(0.5);
        let j = map(motor);
        assert_eq!(j.joint_angle_deg(600.0), -110.0);
        assert_eq!(j.joint_velocity_dps(60.0), -10.0);
        assert_eq!(j.joint_torque_nm(2.0), Some(-1.0));
        assert_eq!(j.motor_amps_for_torque(-1.0), Some(2.0));
        assert_eq!(j.motor_amps(3.0), -3.0);
        assert_eq!(j.motor_angle_deg(-110.0), 600.0);
        // Without a torque constant there is no torque.
        let j = map(MotorConfig::new(1));
        assert_eq!(j.joint_torque_nm(2.0), None);
        assert_eq!(j.motor_amps_for_torque(1.0), None);
    }

    #[test]
    fn power_up_windows_are_centred_where_asked() {
        for d in [Mounting::Normal, Mounting::Reversed] {
            let motor = MotorConfig::new(1)
                .gear_ratio(6.0)
                .direction(d)
                .zero_offset_deg(centred_zero_offset_deg(6.0, d, 12.0));
            let robot = Robot::try_from(
                RobotConfig::new(100.0).with_bus(BusConfig::new("can0").with_motor(motor)),
            )
            .unwrap();
            let (low, high) = power_up_window(&robot.joints()[0]);
            assert!((high - low - 60.0).abs() < 1e-9);
            assert!(
                ((low + high) / 2.0 - 12.0).abs() < 1e-9,
                "{d:?}: {low}..{high}"
            );
        }
    }

    proptest! {
        /// Any motion slower than half a turn per reading, sampled every tick, is tracked exactly.
        #[test]
        fn tracks_any_slow_motion(steps in proptest::collection::vec(-8000i64..8000, 1..200), start in 0i64..16384) {
            let mut u = w14();
            let mut truth = start;
            u.update(start as u16, 0.0, MS);
            for s in steps {
                truth += s;
                let speed = s as f64 * 360.0 / 16384.0 / MS.as_secs_f64();
                let reading = truth.rem_euclid(16384) as u16;
                let got = u.update(reading, speed, MS);
                prop_assert!((got - truth as f64 * 360.0 / 16384.0).abs() < 1e-6);
            }
        }

        /// Rounding agrees with the library's `round` (halves away from zero) for any double
        /// within +-2^52, and for halves and their neighbours.
        #[test]
        fn nearest_integer_is_the_librarys_round(x in -ALL_INTEGERS..=ALL_INTEGERS, n in -(1i64 << 40)..(1i64 << 40)) {
            prop_assert_eq!(nearest_integer_within(x, -ALL_INTEGERS, ALL_INTEGERS), x.round() as i64);
            let half = n as f64 + 0.5;
            for y in [half, half.next_down(), half.next_up(), -half, -half.next_down()] {
                prop_assert_eq!(nearest_integer_within(y, -ALL_INTEGERS, ALL_INTEGERS), y.round() as i64, "{}", y);
            }
        }

        /// Garbage never panics.
        #[test]
        fn never_panics(readings in proptest::collection::vec((any::<u16>(), any::<f64>(), any::<u64>()), 1..50)) {
            let mut u = EncoderUnwrapper::new(EncoderWidth::new(18).unwrap());
            for (r, s, ns) in readings {
                let _ = u.update(r, s, Duration::from_nanos(ns));
            }
        }
    }
}

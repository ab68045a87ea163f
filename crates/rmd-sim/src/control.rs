//! The firmware's closed loops, run every [`SUBSTEP`](crate::physics::SUBSTEP).
//!
//! The spec gives the PID gains as raw bytes without units. The simulated firmware maps them
//! to physical gains with fixed scales chosen so that the default gains give a well-damped
//! motor with the default parameters (engineering estimates, not the manufacturer's):
//!
//! - torque loop: the current follows its reference as a first-order lag whose time constant is
//!   the motor's `current_time_constant_s` x 50 / `iqPidKp` (a PI current loop tuned by
//!   pole-zero cancellation has a bandwidth proportional to its Kp); `iqPidKi` is kept but has
//!   no further effect;
//! - speed loop: a PI controller with setpoint weighting,
//!   `i = Kp (w_ref_weight x w_ref - w) + Ki ∫(w_ref - w) dt`, `Kp = speedPidKp x 0.0067 A/(rad/s)`,
//!   `Ki = speedPidKi x 0.44 A/rad`. With the defaults (50, 40) and the default inertia the
//!   closed loop has `a = Kp Kt / J = 299 /s`, `b = Ki Kt / J = 15 700 /s²` (poles at -68 and
//!   -231 /s, damping 1.19). In speed mode the weight is 0.7: the zero `b / (0.7 a)` then lies
//!   beyond the slow pole, so the response to the acceleration ramp rises monotonically and
//!   never exceeds the ramp's acceleration; the ramped reference is also kept within the loop's
//!   steady ramp lag (`0.3 Kp / Ki` x acceleration) of the measured speed, so that a rotor held
//!   by stiction does not wind the loop up. In position mode the weight is 1 (plain PI). The
//!   output is clamped to the max torque current, the integrator held at the clamp
//!   (anti-windup);
//! - position loop: a motion profile (trapezoidal: the max speed and the acceleration limit)
//!   moves a reference from the current position to the target; the speed loop gets the
//!   profile's speed plus `angleKp x (reference - position)` with `angleKp = anglePidKp x 0.3 /s`,
//!   limited to the max speed, and the profile's acceleration is fed forward through the rotor's
//!   own inertia (the firmware knows its motor, not the load). `anglePidKi` is kept but has no
//!   effect (the speed loop's integral removes the steady-state error, gravity included).
//!
//! The speed the loops use is the plant's exact speed: the firmware's filtered encoder
//! derivative is modelled as perfect.

use rmd_protocol::PidParams;

/// Raw-to-physical scale of `speedPidKp`, A per rad/s.
pub(crate) const SPEED_KP_PER_LSB: f64 = 0.0067;
/// Raw-to-physical scale of `speedPidKi`, A per rad.
pub(crate) const SPEED_KI_PER_LSB: f64 = 0.44;
/// Raw-to-physical scale of `anglePidKp`, 1/s.
pub(crate) const ANGLE_KP_PER_LSB: f64 = 0.3;
/// The `iqPidKp` at which the current loop has the motor's nominal time constant.
pub(crate) const NOMINAL_IQ_KP: f64 = 50.0;

/// Physical gains of the firmware's three loops.
#[derive(Copy, Clone, Debug, PartialEq)]
pub(crate) struct FirmwareGains {
    pub(crate) speed_kp: f64,
    pub(crate) speed_ki: f64,
    pub(crate) angle_kp: f64,
    pub(crate) current_time_constant_s: f64,
}

impl FirmwareGains {
    pub(crate) fn from_pid(pid: &PidParams, nominal_time_constant_s: f64) -> Self {
        Self {
            speed_kp: f64::from(pid.speed_pid_kp) * SPEED_KP_PER_LSB,
            speed_ki: f64::from(pid.speed_pid_ki) * SPEED_KI_PER_LSB,
            angle_kp: f64::from(pid.angle_pid_kp) * ANGLE_KP_PER_LSB,
            current_time_constant_s: nominal_time_constant_s * NOMINAL_IQ_KP
                / f64::from(pid.iq_pid_kp.max(1)),
        }
    }
}

impl FirmwareGains {
    /// The speed loop's steady-state lag behind a reference ramping at 1 rad/s², in seconds:
    /// `(1 - weight) Kp / Ki` (independent of the inertia). Infinite without an integral.
    pub(crate) fn ramp_lag_s(&self, setpoint_weight: f64) -> f64 {
        if self.speed_ki > 0.0 {
            (1.0 - setpoint_weight) * self.speed_kp / self.speed_ki
        } else {
            f64::INFINITY
        }
    }
}

/// State of the speed and position loops.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(crate) struct LoopState {
    /// Speed reference after the acceleration ramp, rad/s.
    pub(crate) speed_ref: f64,
    /// Speed-loop integrator, A.
    pub(crate) integral_a: f64,
    /// Position profile: reference position, rad (firmware frame).
    pub(crate) profile_pos: f64,
    /// Position profile: reference speed, rad/s.
    pub(crate) profile_vel: f64,
}

impl LoopState {
    /// Bumpless start from the measured state: no jump of speed reference or current.
    pub(crate) fn start(
        position: f64,
        speed: f64,
        current_a: f64,
        setpoint_weight: f64,
        gains: &FirmwareGains,
    ) -> Self {
        Self {
            speed_ref: speed,
            integral_a: current_a + gains.speed_kp * (1.0 - setpoint_weight) * speed,
            profile_pos: position,
            profile_vel: speed,
        }
    }
}

/// Moves `value` towards `target` by at most `max_step` (no limit if `max_step` is infinite).
pub(crate) fn ramp(value: f64, target: f64, max_step: f64) -> f64 {
    value + (target - value).clamp(-max_step, max_step)
}

/// Weight of the speed reference in the proportional term of the speed loop (2-DOF PI) in
/// speed mode: with 0.7 the response to the acceleration ramp has no overshoot.
pub(crate) const SPEED_MODE_SETPOINT_WEIGHT: f64 = 0.7;
/// The same in position mode, where the profile's acceleration is fed forward: a plain PI.
pub(crate) const POSITION_MODE_SETPOINT_WEIGHT: f64 = 1.0;

/// One step of the speed loop (a PI with setpoint weighting); returns the current reference, A.
pub(crate) fn speed_loop(
    state: &mut LoopState,
    reference: f64,
    measured: f64,
    setpoint_weight: f64,
    gains: &FirmwareGains,
    max_current_a: f64,
    dt: f64,
) -> f64 {
    state.integral_a += gains.speed_ki * (reference - measured) * dt;
    let proportional = gains.speed_kp * (setpoint_weight * reference - measured);
    let unclamped = state.integral_a + proportional;
    let out = unclamped.clamp(-max_current_a, max_current_a);
    if out != unclamped {
        state.integral_a = out - proportional;
    }
    out
}

/// One step of the position profile towards `target` with speed limit `max_speed` and
/// acceleration limit `max_accel` (both > 0; infinite for none). Stops exactly on the target.
///
/// The braking curve is the discrete one: after a step with speed `v = x a dt`, braking at `a`
/// covers `a dt² x (x - 1) / 2`, so the remaining distance `e` allows
/// `x <= (sqrt(1 + 8 e / (a dt²)) - 1) / 2`. The speed is also kept at or below `e / dt`, so the
/// last step lands on the target at a speed of at most `a dt`, then stops.
pub(crate) fn profile_step(
    state: &mut LoopState,
    target: f64,
    max_speed: f64,
    max_accel: f64,
    dt: f64,
) {
    let error = target - state.profile_pos;
    if error == 0.0 && state.profile_vel == 0.0 {
        return;
    }
    let braking = if max_accel.is_finite() {
        let e = error.abs() / (max_accel * dt * dt);
        max_accel * dt * ((1.0 + 8.0 * e).sqrt() - 1.0) / 2.0
    } else {
        f64::INFINITY
    };
    let desired = error.signum() * max_speed.min(braking).min(error.abs() / dt);
    state.profile_vel = ramp(state.profile_vel, desired, max_accel * dt);
    let next = state.profile_pos + state.profile_vel * dt;
    let reached = (target - next) * error <= 0.0;
    if reached && state.profile_vel.abs() <= max_accel * dt * (1.0 + 1e-9) {
        state.profile_pos = target;
        state.profile_vel = 0.0;
    } else {
        // Not there yet, or coming in too fast (a new target right ahead of a fast motion):
        // go on, pass it and come back within the limits.
        state.profile_pos = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_profile_respects_speed_and_acceleration_and_stops_on_target() {
        let mut s = LoopState::default();
        let dt = 50e-6;
        let (vmax, amax) = (10.0, 100.0);
        // Check the motion itself: speeds and accelerations from successive positions.
        let mut last_pos = 0.0;
        let mut last_v: f64 = 0.0;
        let mut steps = 0;
        while !(s.profile_pos == 5.0 && s.profile_vel == 0.0) {
            profile_step(&mut s, 5.0, vmax, amax, dt);
            let v = (s.profile_pos - last_pos) / dt;
            assert!(v <= vmax * (1.0 + 1e-9), "step {steps}: speed {v}");
            assert!(
                (v - last_v).abs() <= amax * dt * (1.0 + 1e-6),
                "step {steps}: {last_v} -> {v}"
            );
            assert!(s.profile_pos <= 5.0);
            last_pos = s.profile_pos;
            last_v = v;
            steps += 1;
            assert!(steps < 1_000_000);
        }
        // Trapezoid: 0.1 s up to 10 rad/s (0.5 rad), 0.4 s cruise (4 rad), 0.1 s down (0.5 rad):
        // 0.6 s = 12 000 steps.
        assert!((11_990..12_010).contains(&steps), "{steps} steps");
        // It stays there.
        profile_step(&mut s, 5.0, vmax, amax, dt);
        assert_eq!((s.profile_pos, s.profile_vel), (5.0, 0.0));
    }

    #[test]
    fn an_unlimited_profile_jumps_at_max_speed_and_lands_exactly() {
        let mut s = LoopState::default();
        profile_step(&mut s, 1e-4, 1.0, f64::INFINITY, 50e-6);
        // 1 rad/s x 50 us = 5e-5 rad per step: two steps.
        assert_eq!(s.profile_pos, 5e-5);
        profile_step(&mut s, 1e-4, 1.0, f64::INFINITY, 50e-6);
        assert_eq!((s.profile_pos, s.profile_vel), (1e-4, 0.0));
    }

    #[test]
    fn the_speed_loop_clamps_and_does_not_wind_up() {
        let gains = FirmwareGains {
            speed_kp: 0.3,
            speed_ki: 20.0,
            angle_kp: 30.0,
            current_time_constant_s: 2e-4,
        };
        let mut s = LoopState::default();
        for _ in 0..10_000 {
            let i = speed_loop(&mut s, 100.0, 0.0, 0.7, &gains, 5.0, 50e-6);
            assert!(i <= 5.0);
        }
        // Held at the clamp: as soon as the error reverses, the output leaves the clamp.
        let i = speed_loop(&mut s, 0.0, 1.0, 0.7, &gains, 5.0, 50e-6);
        assert!(i < 5.0);
    }
}

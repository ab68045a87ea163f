//! `rmd monitor --sim --demo`: a gentle motion for the simulated motors, so that the plots have
//! something to show: each motor follows a slow sine of its own phase around the angle it had
//! when the monitor started, in position mode 2 (0xA4, with a speed limit), one command per
//! reading. The sine grows from nothing over its first period, so nothing jumps at the start.

use core::f64::consts::PI;

use rmd_protocol::{AngleControl, MaxSpeed, Request};

/// Amplitude of each motor's sine, motor degrees (a ninth of that at a 1:9 joint).
pub(crate) const AMPLITUDE_DEG: f64 = 90.0;
/// Period of the sine, seconds.
pub(crate) const PERIOD_S: f64 = 6.0;
/// The speed limit of the position commands, motor degrees per second (above the sine's peak
/// speed, 2 pi A / T = 94 dps, plus the growth of its first period).
const MAX_SPEED_DPS: f64 = 200.0;

/// Motor `index`'s target at `time_s`, motor degrees: around `centre_deg`, a sine a quarter
/// period after the one of the motor before it, its amplitude growing over the first period.
pub(crate) fn target_deg(centre_deg: f64, index: usize, time_s: f64) -> f64 {
    let growth = (time_s / PERIOD_S).clamp(0.0, 1.0);
    let phase = 2.0 * PI * time_s / PERIOD_S + index as f64 * PI / 2.0;
    centre_deg + growth * AMPLITUDE_DEG * phase.sin()
}

/// The position command towards motor `index`'s target at `time_s`.
pub(crate) fn command(centre_deg: f64, index: usize, time_s: f64) -> Result<Request, String> {
    Ok(Request::Position2 {
        max_speed: MaxSpeed::from_dps(MAX_SPEED_DPS).map_err(|e| e.to_string())?,
        angle_control: AngleControl::from_degrees(target_deg(centre_deg, index, time_s))
            .map_err(|e| e.to_string())?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_motor_follows_its_own_gentle_sine_around_its_start() {
        // Nothing moves at the start, whatever the phase.
        for index in 0..4 {
            assert_eq!(target_deg(12.5, index, 0.0), 12.5);
        }
        // After the first period: full amplitude, a quarter period between neighbours.
        let t = PERIOD_S + PERIOD_S / 4.0;
        assert!((target_deg(0.0, 0, t) - AMPLITUDE_DEG).abs() < 1e-9);
        assert!(target_deg(0.0, 1, t).abs() < 1e-9);
        assert!((target_deg(-30.0, 2, t) - (-30.0 - AMPLITUDE_DEG)).abs() < 1e-9);
        // Half way through the growth: half the amplitude.
        let quarter = PERIOD_S / 4.0;
        assert!((target_deg(0.0, 0, quarter) - AMPLITUDE_DEG / 4.0).abs() < 1e-9);
        // The fastest the target moves stays under the speed limit.
        let fastest = (0..6000)
            .map(|k| {
                let t = f64::from(k) * 0.001;
                (target_deg(0.0, 1, t + 0.001) - target_deg(0.0, 1, t)).abs() / 0.001
            })
            .fold(0.0, f64::max);
        assert!(fastest < MAX_SPEED_DPS, "{fastest}");
        let Ok(Request::Position2 { angle_control, .. }) = command(10.0, 0, t) else {
            panic!("a position command");
        };
        assert!((angle_control.degrees() - (10.0 + AMPLITUDE_DEG)).abs() < 0.01);
    }
}

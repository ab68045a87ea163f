//! After the replies: what did not come, and what came out of range.

use super::Exchange;
use crate::report::Fault;
use crate::stats::LoopStats;

impl<B> Exchange<B> {
    /// Counts every joint without fresh feedback this tick; a joint silent for
    /// `fault_after` consecutive ticks, or reporting a temperature at or above its limit, is a
    /// fault. Returns whether every joint was fresh.
    pub(crate) fn account(
        &mut self,
        fault_after: u32,
        stats: &mut LoopStats,
    ) -> Result<bool, Fault> {
        let mut all_fresh = true;
        for (m, (motor, feedback)) in self.motors.iter_mut().zip(&self.feedback).enumerate() {
            motor.end_tick(feedback);
            if feedback.is_fresh() {
                motor.consecutive_missing = 0;
            } else {
                all_fresh = false;
                motor.consecutive_missing = motor.consecutive_missing.saturating_add(1);
                stats.missing_total += 1;
                let counters = &mut stats.motors[m];
                counters.missing_replies += 1;
                counters.max_consecutive_missing = counters
                    .max_consecutive_missing
                    .max(u64::from(motor.consecutive_missing));
                if motor.consecutive_missing >= fault_after {
                    return Err(Fault::NoFreshFeedback {
                        at: motor.at,
                        ticks: motor.consecutive_missing,
                    });
                }
            }
            let celsius = feedback.motor.temperature_celsius;
            if let Some(limit) = motor.temperature_limit
                && celsius >= limit
            {
                return Err(Fault::OverTemperature {
                    at: motor.at,
                    celsius,
                });
            }
        }
        Ok(all_fresh)
    }
}

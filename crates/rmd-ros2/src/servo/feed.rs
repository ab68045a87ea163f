//! [`LoopFeed`]: what the owner of the loop's [`LoopHandle`](rmd_loop::LoopHandle) tells the
//! port about the loop: statistics snapshots while it runs, and how it ended.

use std::sync::{Arc, Mutex, PoisonError};

use rmd_loop::{Fault, LoopReport, StopReason, robot::Robot, stats::StatsSummary};

/// A shared slot between the thread that owns the loop's handle (it takes
/// [`LoopHandle::snapshot`](rmd_loop::LoopHandle::snapshot)s and, at the end, the report) and
/// the port on the node's thread (it reads them for `diagnostics`). Cheap to clone; both sides
/// are ordinary threads (the slot's lock is never near the loop thread).
///
/// ```
/// use rmd_ros2::servo::LoopFeed;
/// let feed = LoopFeed::new();
/// assert!(feed.stats().is_none() && feed.end().is_none());
/// ```
#[derive(Clone, Debug, Default)]
pub struct LoopFeed {
    inner: Arc<Mutex<Fed>>,
}

#[derive(Debug, Default)]
struct Fed {
    stats: Option<StatsSummary>,
    end: Option<LoopEnded>,
}

/// How the loop ended, as the port reports it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LoopEnded {
    /// Why, in words (joints named).
    pub reason: String,
    /// Whether that is a normal end.
    pub normal: bool,
    /// The fault, in words, and the joints it concerns (by index in the robot's joint order;
    /// empty for a fault of the loop as a whole, e.g. deadline misses).
    pub fault: Option<(String, Vec<usize>)>,
    /// Joints whose motor did not confirm motor-off at the end (they may still be energised).
    pub unconfirmed_off: Vec<usize>,
}

impl LoopFeed {
    /// An empty feed.
    pub fn new() -> Self {
        Self::default()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Fed> {
        // Plain data: a panic elsewhere cannot leave it half-written.
        self.inner.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// A new statistics snapshot of the running loop.
    pub fn set_stats(&self, stats: StatsSummary) {
        self.lock().stats = Some(stats);
    }

    /// The loop has ended with `report` (of a loop over `robot`): its final statistics, the
    /// reason, the fault and the motors it concerns.
    pub fn set_ended(&self, report: &LoopReport, robot: &Robot) {
        let fault = match &report.stop_reason {
            StopReason::Fault(fault) => Some((fault.describe(robot), fault_joints(fault, robot))),
            _ => None,
        };
        let unconfirmed_off = report
            .safe_stop
            .unconfirmed()
            .filter_map(|m| robot.joints().iter().position(|j| j.name == m.joint))
            .collect();
        let mut fed = self.lock();
        fed.stats = Some(report.stats.clone());
        fed.end = Some(LoopEnded {
            reason: report.stop_description.clone(),
            normal: report.normal_stop,
            fault,
            unconfirmed_off,
        });
    }

    /// The newest statistics, if any.
    pub fn stats(&self) -> Option<StatsSummary> {
        self.lock().stats.clone()
    }

    /// How the loop ended, once it has.
    pub fn end(&self) -> Option<LoopEnded> {
        self.lock().end.clone()
    }
}

/// The joints a fault is about (by index): its motor's, or every joint of its bus.
fn fault_joints(fault: &Fault, robot: &Robot) -> Vec<usize> {
    let on_bus = |bus: usize| -> Vec<usize> {
        robot
            .joints()
            .iter()
            .enumerate()
            .filter(|(_, j)| j.bus == bus)
            .map(|(i, _)| i)
            .collect()
    };
    match fault {
        Fault::NoFreshFeedback { at, .. }
        | Fault::StartupTimeout { at, .. }
        | Fault::OverTemperature { at, .. }
        | Fault::MotorError { at, .. }
        | Fault::Firmware { at, .. }
        | Fault::MotionRanges { at, .. } => vec![at.joint.index()],
        Fault::BusOff { bus } | Fault::Bus { bus, .. } | Fault::UndescribedMotor { bus, .. } => {
            on_bus(*bus)
        }
        Fault::RejectedCommand {
            joint: Some(joint), ..
        } => vec![joint.index()],
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rmd_loop::MotorRef;
    use rmd_protocol::MotorId;

    fn robot() -> Robot {
        Robot::from_toml(
            "[[bus]]\ninterface = \"sim\"\n[[bus.motor]]\nid = 1\nname = \"a\"\n[[bus.motor]]\nid = 2\nname = \"b\"\n\
             [[bus]]\nname = \"second\"\ninterface = \"sim\"\n[[bus.motor]]\nid = 1\nname = \"c\"",
        )
        .unwrap()
    }

    #[test]
    fn faults_point_at_their_motor_or_their_bus() {
        let r = robot();
        let at = MotorRef {
            joint: r.joint("b").unwrap(),
            bus: 0,
            motor: MotorId::new(2).unwrap(),
        };
        assert_eq!(
            fault_joints(&Fault::OverTemperature { at, celsius: 80.0 }, &r),
            [1]
        );
        assert_eq!(fault_joints(&Fault::BusOff { bus: 0 }, &r), [0, 1]);
        assert_eq!(fault_joints(&Fault::BusOff { bus: 1 }, &r), [2]);
        assert!(fault_joints(&Fault::DeadlineMisses { consecutive: 3 }, &r).is_empty());
    }
}

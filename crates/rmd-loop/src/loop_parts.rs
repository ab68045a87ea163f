//! Everything a loop owns besides its controller: the robot, the clock, the exchange, the
//! statistics, what it shares with other threads, and the per-tick command buffers. The engine
//! runs the tick on it; the start-up and the finish take it in turn.

use std::sync::Arc;

use crate::commands::{MAX_SIGNALS, PackedMotion, Rejections};
use crate::exchange::Exchange;
use crate::guard::LimitGuard;
use crate::loop_link::LoopLink;
use crate::mapping::JointMap;
use crate::motion::MotionMap;
use crate::robot::Robot;
use crate::stats::LoopStats;
use crate::telemetry::{TelemetryDelivery, TelemetrySender, TickTimes};

/// Everything a loop owns besides its controller, before and after it starts.
#[derive(Debug)]
pub(crate) struct LoopParts<B, C> {
    pub(crate) robot: Robot,
    pub(crate) clock: C,
    pub(crate) exchange: Exchange<B>,
    pub(crate) stats: LoopStats,
    pub(crate) shared: Arc<LoopLink>,
    pub(crate) maps: Vec<JointMap>,
    /// Each joint's limits, as the tick checks them.
    pub(crate) guards: Vec<LimitGuard>,
    /// Whether any joint has a limit (a robot without them pays one branch per tick).
    pub(crate) limits_on: bool,
    /// Motor-side amperes per joint: the controller's commands, then what was staged.
    pub(crate) command_amps: Vec<f64>,
    /// Per joint, its motion-mode conversions (`None` off a `motion` bus); empty when no bus
    /// is a `motion` bus.
    pub(crate) motion_maps: Vec<Option<MotionMap>>,
    /// Per joint, this tick's motion setpoint (as long as `motion_maps`).
    pub(crate) command_motion: Vec<Option<PackedMotion>>,
    pub(crate) signals: [f64; MAX_SIGNALS],
    pub(crate) signal_count: usize,
    pub(crate) rejections: Rejections,
    pub(crate) telemetry: Option<(TelemetrySender, TelemetryDelivery)>,
    /// This tick's timings so far, for its telemetry sample.
    pub(crate) times: TickTimes,
}

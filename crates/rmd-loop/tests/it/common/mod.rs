//! Shared set-up of the loop's simulator tests: a 4-motor leg on one simulated bus (or several),
//! RMD-X8-class motors (1:9 gearbox, 2.09 N*m/A at the output), in virtual time.
#![allow(dead_code, unreachable_pub)]

use core::time::Duration;

use rmd_bus::VirtualClock;
use rmd_loop::robot::{BusConfig, MotorConfig, Robot, RobotConfig};
use rmd_loop::{Commands, Controller, Fault, Feedback, Flow, StopReason, TickContext};
use rmd_protocol::MotorId;
use rmd_sim::{ControlMode, FaultRule, SimBus, SimConfig};

/// Gear ratio of the simulator's default motor.
pub const GEAR: f64 = 9.0;
/// Output torque constant of the simulator's default motor.
pub const KT: f64 = 2.09;

pub fn id(n: u8) -> MotorId {
    MotorId::new(n).unwrap()
}

/// `buses` buses with motors 1..=n each, at `rate_hz`.
pub fn robot(rate_hz: f64, buses: usize, motors: u8) -> Robot {
    Robot::try_from(robot_config(rate_hz, buses, motors)).unwrap()
}

/// [`robot`] for runs in real time that are not about stalls: a loaded machine may not run the
/// loop thread for tens of milliseconds now and then, beyond the default stall bound of 50 ms
/// (which is a fault, and says the OS did it). The bound here is the longest allowed.
pub fn realtime_robot(rate_hz: f64, buses: usize, motors: u8) -> Robot {
    let mut config = robot_config(rate_hz, buses, motors);
    config.loop_config.stall_bound_ms = Some(60_000);
    Robot::try_from(config).unwrap()
}

/// The file form of [`robot`], to change before building.
pub fn robot_config(rate_hz: f64, buses: usize, motors: u8) -> RobotConfig {
    let mut robot = RobotConfig::new(rate_hz);
    for b in 0..buses {
        let mut bus = BusConfig::new(&format!("sim{b}"));
        for m in 1..=motors {
            bus = bus.with_motor(
                MotorConfig::new(m)
                    .gear_ratio(GEAR)
                    .torque_constant(KT)
                    .current_limit(10.0),
            );
        }
        robot = robot.with_bus(bus);
    }
    robot
}

/// A simulated bus with motors 1..=n on `clock`, seed `seed`, and the given fault rules.
pub fn sim(
    clock: &VirtualClock,
    motors: u8,
    seed: u64,
    faults: &[FaultRule],
) -> SimBus<VirtualClock> {
    let mut config = SimConfig::with_motors(motors).seed(seed);
    for f in faults {
        config = config.fault(*f);
    }
    SimBus::new(clock.clone(), config).unwrap()
}

/// Runs a 1 kHz, 4-motor leg on one simulated bus (seed, fault rules) in virtual time for
/// `ticks` ticks with `controller`; returns the outcome and the bus for inspection.
pub fn run_leg<K: Controller>(
    seed: u64,
    faults: &[FaultRule],
    controller: K,
    ticks: u64,
) -> (rmd_loop::LoopOutcome<K>, SimBus<VirtualClock>) {
    let clock = VirtualClock::new();
    let mut bus = sim(&clock, 4, seed, faults);
    let rt = rmd_loop::RtLoop::unsupervised(robot(1000.0, 1, 4), clock, vec![&mut bus], controller)
        .unwrap();
    let out = rt.run(rmd_loop::RunLimit::Ticks(ticks));
    (out, bus)
}

/// Asserts every motor on `bus` is off (the safe state: no torque, no command).
pub fn assert_safe(bus: &mut SimBus<VirtualClock>, motors: u8) {
    for m in 1..=motors {
        let snap = bus.snapshot(id(m)).unwrap();
        assert_eq!(
            snap.mode,
            ControlMode::Off,
            "motor {m} is not off: {snap:?}"
        );
    }
}

/// A PD controller on joint angle towards fixed targets (degrees), in amperes.
#[derive(Debug, Default)]
pub struct PdTo {
    pub targets: Vec<f64>,
    pub kp: f64,
    pub kd: f64,
    pub started: bool,
    pub updates: u64,
    pub stale_seen: u64,
    pub faults: Vec<Fault>,
    pub stop: Option<StopReason>,
    /// Panic in the update of this tick.
    pub panic_at: Option<u64>,
    /// Return Flow::Stop at this tick.
    pub finish_at: Option<u64>,
}

impl PdTo {
    pub fn new(targets: &[f64]) -> Self {
        Self {
            targets: targets.to_vec(),
            kp: 0.4,
            kd: 0.01,
            ..Self::default()
        }
    }
    pub fn hold(n: usize) -> Self {
        Self::new(&vec![0.0; n])
    }
}

impl Controller for PdTo {
    fn start(&mut self, _ctx: &TickContext, feedback: &Feedback<'_>) {
        assert!(feedback.all_fresh(), "start without full feedback");
        self.started = true;
    }

    fn update(&mut self, ctx: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        if self.panic_at == Some(ctx.index) {
            panic!("controller bug at tick {}", ctx.index);
        }
        self.updates += 1;
        for (joint, f) in fb.iter() {
            if !f.is_fresh() {
                self.stale_seen += 1;
            }
            let target = self.targets.get(joint.index()).copied().unwrap_or(0.0);
            let amps = self.kp * (target - f.joint.angle_deg) - self.kd * f.joint.velocity_dps;
            cmd.set_current(joint, amps);
        }
        if self.finish_at == Some(ctx.index) {
            Flow::Stop
        } else {
            Flow::Continue
        }
    }

    fn fault(&mut self, fault: &Fault) {
        self.faults.push(*fault);
    }

    fn stop(&mut self, reason: &StopReason) {
        self.stop = Some(reason.clone());
    }
}

pub const MS: Duration = Duration::from_millis(1);

/// Pushes a constant joint current on every joint.
pub struct Constant(pub f64);

impl Controller for Constant {
    fn update(&mut self, _: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        for (joint, _) in fb.iter() {
            cmd.set_current(joint, self.0);
        }
        Flow::Continue
    }
}

/// Whether any 0x280 frame went out on the simulated wire (recorded with `record_trace`).
pub fn sent_multi_torque(bus: &SimBus<VirtualClock>) -> bool {
    bus.trace()
        .iter()
        .any(|t| t.from == rmd_sim::Node::Host && t.frame.id() == rmd_protocol::MULTI_TORQUE_CAN_ID)
}

/// The loop started, or the test fails with its report (printed first: a panic on a thread
/// that ran the loop is recorded by the loop's hook, not printed).
pub fn started<B: rmd_bus::CanBus, C: rmd_bus::Clock + Clone + 'static, K: Controller>(
    rt: rmd_loop::RtLoop<B, C, K>,
) -> rmd_loop::Running<B, C, K> {
    match rt.start() {
        Ok(running) => running,
        Err(out) => {
            eprintln!("{}", out.report);
            panic!("refused: {}", out.report.stop_description)
        }
    }
}

/// Holds every joint at zero current and watches each motor's health (the status rotation):
/// from tick `from` on, the oldest reading seen (`tick - requested_tick`), whether a joint had
/// none, and the last supply voltage of each.
#[derive(Debug, Default)]
pub struct HealthWatch {
    pub from: u64,
    pub oldest: u64,
    pub without: u64,
    pub volts: Vec<f64>,
}

impl HealthWatch {
    pub fn from(tick: u64) -> Self {
        Self {
            from: tick,
            ..Self::default()
        }
    }
}

impl Controller for HealthWatch {
    fn update(&mut self, ctx: &TickContext, fb: &Feedback<'_>, _: &mut Commands<'_>) -> Flow {
        self.volts.clear();
        for (_, state) in fb.iter() {
            match state.health {
                Some(h) => {
                    self.volts.push(h.voltage_volts);
                    if ctx.index >= self.from {
                        self.oldest = self.oldest.max(ctx.index - h.requested_tick);
                    }
                }
                None if ctx.index >= self.from => self.without += 1,
                None => {}
            }
        }
        Flow::Continue
    }
}

/// The status requests (0x9A) the host sent on `bus`, by motor id (1..=32, index 0 unused).
pub fn status_requests(bus: &SimBus<VirtualClock>) -> Vec<u64> {
    let mut count = vec![0; 33];
    for t in bus.trace() {
        if t.from == rmd_sim::Node::Host && t.frame.data().first() == Some(&0x9A) {
            count[usize::from(t.frame.id() & 0x1F)] += 1;
        }
    }
    count
}

/// The torque replies' counters of `r` untouched by the health rotation (no missing, late,
/// unexpected or bad torque reply), every status request answered but perhaps the last few
/// (`status_replies` at least `least` per motor, none missing).
pub fn assert_rotation_left_torque_alone(r: &rmd_loop::LoopReport, least: u64) {
    assert_eq!(
        (r.stats.missing_replies, r.stats.late_replies),
        (0, 0),
        "{r}"
    );
    for m in &r.stats.motors {
        let c = &m.counters;
        assert_eq!(
            (c.unexpected_replies, c.bad_frames, c.missing_status_replies),
            (0, 0, 0),
            "{m:?}"
        );
        assert!(c.status_replies >= least, "{m:?}");
    }
}

//! Shared set-up of the servo's simulator tests: a 4-joint leg of RMD-X8-class motors (1:9,
//! 2.09 N·m/A at the output, 8 A limit) on one simulated bus at 1 kHz in virtual time, the loop
//! stepped tick by tick on the test thread, the simulated motors readable between ticks.
#![allow(dead_code, unreachable_pub)]

use std::ops::ControlFlow;
use std::sync::Once;

use rmd_bus::VirtualClock;
use rmd_loop::robot::{BusConfig, ExchangeKind, MotorConfig, RobotConfig};
use rmd_loop::{
    LoopOutcome, RtLoop, Running, StopReason, robot::Robot, telemetry::TelemetryReceiver,
};
use rmd_protocol::MotorId;
use rmd_servo::{ServoConfig, ServoController, ServoHandle, ServoState};
use rmd_sim::{MotorSnapshot, SharedSimBus};

/// The joints, in order (motor ids 1..=4).
pub const JOINTS: [&str; 4] = ["hip_aa", "hip_fe", "knee", "ankle"];
/// Loop period, s.
pub const DT: f64 = 0.001;

/// Gains and limits most tests use (stale setpoints never expire unless a test says so).
pub const SERVO: &str = r#"
[defaults]
kp_nm_per_rad = 60.0
kd_nm_s_per_rad = 1.5
max_velocity_rad_s = 2.0
max_acceleration_rad_s2 = 10.0
max_jerk_rad_s3 = 100.0
stale_policy = "never"
"#;

/// The robot: zero offsets centre each power-up window (40 degrees of joint) on 0.
pub fn robot() -> Robot {
    leg(|_, motor| motor)
}

/// The robot with what `change` makes of joint `i`'s motor.
pub fn leg(change: impl Fn(usize, MotorConfig) -> MotorConfig) -> Robot {
    leg_on(1000.0, BusConfig::new("sim"), change)
}

/// The leg on MyActuator V3 motors whose bus exchanges `exchange` (`Motion`: the servo runs
/// its position and velocity modes in the motors), at 500 Hz (four V3 motors on one bus need
/// up to 1080 us an exchange).
pub fn v3_leg(exchange: ExchangeKind) -> Robot {
    let bus = BusConfig::new("sim")
        .protocol("myactuator-v3")
        .exchange(exchange);
    leg_on(500.0, bus, |_, motor| motor)
}

fn leg_on(
    rate_hz: f64,
    mut bus: BusConfig,
    change: impl Fn(usize, MotorConfig) -> MotorConfig,
) -> Robot {
    for (i, name) in JOINTS.iter().enumerate() {
        let motor = MotorConfig::new(i as u8 + 1)
            .name(name)
            .gear_ratio(9.0)
            .torque_constant(2.09)
            .current_limit(8.0)
            .zero_offset_deg(20.0);
        bus = bus.with_motor(change(i, motor));
    }
    Robot::try_from(RobotConfig::new(rate_hz).with_bus(bus)).unwrap()
}

/// A servo in a running loop, stepped by the test.
pub struct Bench {
    pub running: Option<Running<SharedSimBus<VirtualClock>, VirtualClock, ServoController>>,
    /// The simulated bus, shared with the loop (the test reads the motors between ticks).
    pub bus: SharedSimBus<VirtualClock>,
    pub handle: ServoHandle,
    pub robot: Robot,
    /// How the loop ended, if it ended on its own.
    pub outcome: Option<LoopOutcome<ServoController>>,
    /// The loop's telemetry (every tick: feedback, commands, the servo's user signals).
    pub telemetry: TelemetryReceiver,
    /// The loop's clock (virtual time: the test may move it on, as a stalled host would).
    pub clock: VirtualClock,
}

static HOOK: Once = Once::new();

impl Bench {
    /// The leg with `servo` (TOML) and these initial joint angles (degrees), started and
    /// stepped once (so that the servo has published a state).
    pub fn new(servo: &str, initial_deg: [f64; 4]) -> Self {
        Self::on(robot(), servo, initial_deg)
    }

    /// [`Bench::new`] for another robot of the leg's joints (one bus).
    pub fn on(robot: Robot, servo: &str, initial_deg: [f64; 4]) -> Self {
        let config = ServoConfig::from_toml(&robot, servo).unwrap();
        let (controller, handle) = ServoController::new(config);
        Self::with(robot, controller, handle, initial_deg)
    }

    pub fn with(
        robot: Robot,
        controller: ServoController,
        handle: ServoHandle,
        initial_deg: [f64; 4],
    ) -> Self {
        let clock = VirtualClock::new();
        let mut sims = rmd_rig::sim::sim_configs(&robot, 7);
        for (motor, deg) in sims[0].motors.iter_mut().zip(initial_deg) {
            motor.initial_output_angle_deg = deg;
        }
        let bus = rmd_rig::open::sim_buses(&clock, sims).unwrap().remove(0);
        let bus = SharedSimBus::new(bus);
        let mut rt =
            RtLoop::unsupervised(robot.clone(), clock.clone(), vec![bus.clone()], controller)
                .unwrap();
        let telemetry = rt.telemetry();
        let running = match rt.start() {
            Ok(running) => running,
            Err(outcome) => panic!("the loop did not start: {}", outcome.report),
        };
        // The loop's hook records panics on its thread without printing them until the run
        // ends; this test thread steps the loop, so let assertion messages through.
        HOOK.call_once(|| {
            std::panic::set_hook(Box::new(|info| eprintln!("{info}")));
        });
        let mut bench = Self {
            running: Some(running),
            bus,
            handle,
            robot,
            outcome: None,
            telemetry,
            clock,
        };
        bench.step(1);
        bench
    }

    /// Runs `ticks` ticks (fewer if the loop stops).
    pub fn step(&mut self, ticks: usize) {
        for _ in 0..ticks {
            let Some(running) = self.running.as_mut() else {
                return;
            };
            if let ControlFlow::Break(reason) = running.step() {
                let running = self.running.take().unwrap();
                self.outcome = Some(running.finish(reason));
                return;
            }
        }
    }

    /// Runs `seconds` of loop time.
    pub fn run_s(&mut self, seconds: f64) {
        let period = self.robot.settings().period.get().as_secs_f64();
        self.step((seconds / period).round() as usize);
    }

    /// Runs until `done` holds for the state (at most `max_ticks`); whether it did.
    pub fn run_until(
        &mut self,
        max_ticks: usize,
        mut done: impl FnMut(&ServoState) -> bool,
    ) -> bool {
        for _ in 0..max_ticks {
            if self.state().is_some_and(|s| done(&s)) {
                return true;
            }
            self.step(1);
        }
        false
    }

    /// The servo's latest state.
    pub fn state(&self) -> Option<ServoState> {
        self.handle.state()
    }

    /// The simulated motor of joint `i` (ground truth).
    pub fn motor(&self, i: usize) -> MotorSnapshot {
        let id = MotorId::new(i as u8 + 1).unwrap();
        self.bus.lock().snapshot(id).unwrap()
    }

    /// Joint `i`'s true angle, rad (the simulated output; direction normal).
    pub fn truth_rad(&self, i: usize) -> f64 {
        self.motor(i).output_angle_deg.to_radians()
    }

    /// Joint `i`'s true velocity, rad/s.
    pub fn truth_rad_s(&self, i: usize) -> f64 {
        (self.motor(i).motor_speed_dps / 9.0).to_radians()
    }

    /// Ends the run (if it has not ended) and gives the outcome.
    pub fn finish(mut self) -> LoopOutcome<ServoController> {
        match self.running.take() {
            Some(running) => running.finish(StopReason::Requested),
            None => self.outcome.take().unwrap(),
        }
    }
}

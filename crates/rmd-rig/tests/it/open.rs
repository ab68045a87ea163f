//! Opening a robot: simulated motors that match the description (read at their true angle inside
//! the power-up window), typed errors naming the bus, and the runner's telemetry and exit status.

use rmd_bus::VirtualClock;
use rmd_loop::mapping::centred_zero_offset_deg;
use rmd_loop::robot::{BusConfig, MotorConfig, Mounting, RobotConfig};
use rmd_loop::{
    Commands, Controller, Feedback, Flow, JointArray, RtLoop, RunLimit, TickContext, robot::Robot,
};
use rmd_rig::runner::Runner;
use rmd_rig::{Placement, PlacementDefault, Rig, RigError, SimTime, open, sim};
use rmd_sim::ControlMode;

/// Holds every joint at its start angle and remembers the first feedback.
struct Hold {
    first: Option<JointArray<f64>>,
    robot: Robot,
}

impl Controller for Hold {
    fn signals(&self) -> Vec<String> {
        vec!["error_deg".into()]
    }
    fn start(&mut self, _: &TickContext, fb: &Feedback<'_>) {
        self.first = Some(JointArray::from_fn(&self.robot, |j| fb[j].joint.angle_deg));
    }
    fn update(&mut self, _: &TickContext, fb: &Feedback<'_>, cmd: &mut Commands<'_>) -> Flow {
        let first = self.first.as_ref().expect("started");
        for (j, f) in fb.iter() {
            let error = first[j] - f.joint.angle_deg;
            cmd.set_current(j, 0.5 * error - 0.02 * f.joint.velocity_dps);
            cmd.set_signal(0, error);
        }
        Flow::Continue
    }
}

fn leg(directions: [Mounting; 2]) -> Robot {
    let mut bus = BusConfig::new("can0");
    for (i, d) in directions.into_iter().enumerate() {
        bus = bus.with_motor(
            MotorConfig::new(i as u8 + 1)
                .gear_ratio(9.0)
                .torque_constant(2.09)
                .direction(d)
                .zero_offset_deg(centred_zero_offset_deg(9.0, d, -75.0)),
        );
    }
    let mut config = RobotConfig::new(1000.0).with_bus(bus);
    // Real-time runs here are supervised: a loaded test machine must not trip the stall bound.
    config.loop_config.stall_bound_ms = Some(2000);
    Robot::try_from(config).unwrap()
}

/// The loop reads the simulated joint's true angle when it powers up inside its window, for
/// either direction, several motor turns away from the encoder's zero; outside it, it is off by
/// whole motor turns (which is why geared joints are homed).
#[test]
fn simulated_joints_read_their_true_angle_inside_the_power_up_window() {
    for (start, inside) in [(-75.0, true), (-90.0, true), (-60.0, true), (-100.0, false)] {
        let robot = leg([Mounting::Normal, Mounting::Reversed]);
        let mut sims = sim::sim_configs(&robot, 3);
        for (m, joint) in sims[0].motors.iter_mut().zip(robot.joints()) {
            m.initial_output_angle_deg = sim::sim_output_angle_deg(joint, start);
        }
        let clock = VirtualClock::new();
        let mut buses = open::sim_buses(&clock, sims).unwrap();
        let hold = Hold {
            first: None,
            robot: robot.clone(),
        };
        let rt = RtLoop::unsupervised(
            robot.clone(),
            clock.clone(),
            buses.iter_mut().collect(),
            hold,
        )
        .unwrap();
        let out = rt.run(RunLimit::Ticks(200));
        assert!(out.report.normal_stop, "{}", out.report);
        let first = out.controller.first.unwrap();
        for (j, read) in first.iter() {
            if inside {
                assert!(
                    (read - start).abs() < 0.05,
                    "{j}: read {read}, true {start}"
                );
            } else {
                let turns = (read - start) / 40.0;
                assert!(
                    (turns.round() - turns).abs() < 0.01 && turns.round() != 0.0,
                    "{read}"
                );
            }
        }
        // Held where it started, and off at the end.
        for joint in robot.joints() {
            let snap = buses[0].snapshot(joint.motor).unwrap();
            assert_eq!(snap.mode, ControlMode::Off);
            let truth = joint.direction.sign() * start;
            assert!((snap.output_angle_deg - truth).abs() < 0.5, "{snap:?}");
        }
    }
}

#[test]
fn open_builds_working_simulated_buses_on_the_chosen_clock() {
    let robot = leg([Mounting::Normal; 2]);
    for time in [SimTime::Virtual, SimTime::Real] {
        let placement = Placement::simulated(&robot, time);
        let rig = Rig::open(&robot, &placement, sim::sim_configs(&robot, 1)).unwrap();
        assert_eq!(rig.buses.len(), 1);
        assert!(rig.buses[0].sim().is_some());
        assert_eq!(rig.clock.is_virtual(), time == SimTime::Virtual);
        let hold = Hold {
            first: None,
            robot: robot.clone(),
        };
        let sim = rig.buses[0].sim().unwrap().clone();
        let rt = rig.into_loop(robot.clone(), hold).unwrap();
        let out = rt.run(RunLimit::Ticks(50));
        assert_eq!(out.report.stats.ticks, 50);
        assert!(out.report.safe_stop.all_off_confirmed());
        // The simulated motors themselves are off.
        for joint in robot.joints() {
            assert_eq!(
                sim.lock().snapshot(joint.motor).unwrap().mode,
                ControlMode::Off
            );
        }
    }
}

#[test]
fn bad_simulated_motors_and_counts_are_typed_errors_naming_the_bus() {
    let robot = leg([Mounting::Normal; 2]);
    let placement = Placement::simulated(&robot, SimTime::Virtual);
    let mut sims = sim::sim_configs(&robot, 1);
    sims[0].motors[1].load.output_inertia_kg_m2 = -1.0;
    let err = Rig::open(&robot, &placement, sims).unwrap_err();
    assert!(
        matches!(&err, RigError::Sim { bus, .. } if bus == "bus0"),
        "{err}"
    );
    let err = Rig::open(&robot, &placement, Vec::new()).unwrap_err();
    assert!(matches!(
        err,
        RigError::SimCount {
            expected: 1,
            given: 0
        }
    ));
}

#[cfg(target_os = "linux")]
#[test]
fn a_missing_interface_is_a_typed_error_naming_the_bus() {
    let robot = Robot::from_toml(
        "[[bus]]\nname = \"leg\"\ninterface = \"rmdnosuch0\"\n[[bus.motor]]\nid = 1",
    )
    .unwrap();
    let placement = Placement::resolve(
        &robot,
        &rmd_rig::placement::Overrides::default(),
        PlacementDefault::Described,
    )
    .unwrap();
    let err = Rig::open(&robot, &placement, sim::sim_configs(&robot, 1)).unwrap_err();
    assert!(
        matches!(&err, RigError::Open { bus, .. } if bus == "leg"),
        "{err}"
    );
    assert!(err.to_string().contains("rmdnosuch0"), "{err}");
}

#[test]
fn the_runner_writes_every_tick_to_csv_and_mcap_with_joint_and_signal_columns() {
    let robot = leg([Mounting::Normal; 2]);
    let placement = Placement::simulated(&robot, SimTime::Virtual);
    let rig = Rig::open(&robot, &placement, sim::sim_configs(&robot, 2)).unwrap();
    let hold = Hold {
        first: None,
        robot: robot.clone(),
    };
    let rt = RtLoop::unsupervised(robot, rig.clock, rig.buses, hold).unwrap();
    let dir = tempfile::tempdir().unwrap();
    // A folder that does not exist yet: the runner creates it.
    let path = dir.path().join("out").join("run.csv");
    let mcap = dir.path().join("run.mcap");
    let finished = Runner::new()
        .csv(Some(&path))
        .mcap(Some(&mcap))
        .run(rt, RunLimit::Ticks(3000))
        .unwrap();
    assert_eq!(finished.exit_status(), rmd_rig::runner::EXIT_OK);
    assert!(!finished.interrupted);
    assert_eq!(finished.outcome.report.stats.telemetry_drops, 0);
    let telemetry = finished.telemetry.as_ref().unwrap();
    assert_eq!(telemetry.samples, 3000);
    assert!(telemetry.complete(), "{telemetry}");
    let names: Vec<&str> = telemetry.sinks().iter().map(|s| s.name.as_str()).collect();
    assert!(
        names[0].starts_with("mcap ") && names[1].starts_with("csv "),
        "{names:?}"
    );
    assert!(telemetry.sinks().iter().all(|s| s.written == 3000));
    assert!(std::fs::metadata(&mcap).unwrap().len() > 0);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header[..3], ["time_s", "tick", "bus0_motor1.position_rad"]);
    let error_column = header.iter().position(|c| *c == "error_deg").unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 3000);
    assert!(rows.iter().all(|r| r.len() == header.len()));
    // Tick numbers run 0..3000 in order, 1 ms apart; the hold error stays small.
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(row[1], k.to_string());
        let time: f64 = row[0].parse().unwrap();
        assert!((time - k as f64 * 1e-3).abs() < 1e-9, "{time}");
        let error: f64 = row[error_column].parse().unwrap();
        assert!(error.abs() < 1.0, "tick {k}: {error}");
    }
}

//! Behaviour of the public API: options, errors, online form.

use rmd_traj::{
    ControlInterface, Direction, DurationDiscretization, Input, InputField, InvalidOption,
    InvalidReason, OnlineGenerator, OnlineStatus, ProfileKind, ReachedLimits, Synchronization,
    TrajectoryError, calculate,
};

fn unit_limits<const N: usize>() -> Input<N> {
    Input::with_limits([1.0; N], [1.0; N], [1.0; N])
}

#[test]
fn rest_to_rest_matches_closed_form() {
    // vMax 1, aMax 1, jMax 1, distance 1: no plateau reached; T = 4·(1/2)^(1/3) exactly.
    let mut input = unit_limits::<1>();
    input.target_position = [1.0];
    let traj = calculate(&input).unwrap();
    let exact = 4.0 * 0.5f64.cbrt();
    assert!(
        (traj.duration() - exact).abs() < 1e-14,
        "{}",
        traj.duration()
    );
    let end = traj.state_at(traj.duration())[0];
    assert_eq!(
        (end.position, end.velocity, end.acceleration, end.jerk),
        (1.0, 0.0, 0.0, 0.0)
    );
    assert_eq!(
        traj.profile(0).unwrap().kind(),
        ProfileKind::TimeOptimal {
            direction: Direction::Up,
            limits: ReachedLimits::None
        }
    );
    // Jerk is right-continuous: at t = 0 it is the first phase's.
    assert_eq!(traj.state_at(0.0)[0].jerk, 1.0);
}

#[test]
fn already_at_moving_target_takes_zero_time() {
    let mut input = unit_limits::<1>();
    input.current_velocity = [0.5];
    input.target_velocity = [0.5];
    input.current_position = [3.0];
    input.target_position = [3.0];
    let traj = calculate(&input).unwrap();
    assert_eq!(traj.duration(), 0.0);
    assert_eq!(traj.profile(0).unwrap().kind(), ProfileKind::AtTarget);
    // It keeps moving at the target velocity afterwards.
    let later = traj.state_at(2.0)[0];
    assert_eq!((later.position, later.velocity), (4.0, 0.5));
}

#[test]
fn moving_target_axis_loops_when_another_axis_needs_time() {
    // Axis 0 is at its moving target; axis 1 needs time: axis 0 must leave and come back, so the
    // common duration is at least the loop of axis 0 (its blocked interval (0, loop) is avoided).
    let mut input = unit_limits::<2>();
    input.current_velocity = [0.5, 0.0];
    input.target_velocity = [0.5, 0.0];
    input.target_position = [0.0, 0.01];
    let traj = calculate(&input).unwrap();
    let mins = traj.independent_min_durations();
    assert_eq!(mins[0], 0.0);
    assert!(traj.duration() > mins[1]);
    for (i, s) in traj.state_at(traj.duration()).iter().enumerate() {
        assert!((s.position - input.target_position[i]).abs() < 1e-9);
        assert!((s.velocity - input.target_velocity[i]).abs() < 1e-9);
    }
}

#[test]
fn synchronized_axes_arrive_together() {
    let mut input = Input::<3>::with_limits([2.0, 1.0, 3.0], [1.0, 2.0, 1.0], [3.0, 1.0, 2.0]);
    input.target_position = [5.0, -1.0, 0.5];
    input.current_velocity = [0.0, 0.3, -0.2];
    let traj = calculate(&input).unwrap();
    assert_eq!(traj.limiting_axis(), Some(0));
    for p in traj.profiles() {
        assert!((p.duration() - traj.duration()).abs() < 1e-12);
    }
}

#[test]
fn minimum_duration_and_discretization() {
    let mut input = unit_limits::<1>();
    input.target_position = [1.0];
    input.minimum_duration = Some(5.0);
    let traj = calculate(&input).unwrap();
    assert_eq!(traj.duration(), 5.0);
    assert_eq!(traj.limiting_axis(), None);

    let mut input = unit_limits::<2>();
    input.target_position = [1.0, 0.3];
    input.duration_discretization = DurationDiscretization::Discrete { period: 0.01 };
    let traj = calculate(&input).unwrap();
    let cycles = traj.duration() / 0.01;
    assert!(
        (cycles - cycles.round()).abs() < 1e-9,
        "{}",
        traj.duration()
    );
    for p in traj.profiles() {
        assert!((p.duration() - traj.duration()).abs() < 1e-12);
    }
}

#[test]
fn synchronization_none_and_time_if_necessary_keep_own_profiles() {
    let mut input = unit_limits::<2>();
    input.target_position = [1.0, 0.1];
    input.synchronization = Synchronization::None;
    let traj = calculate(&input).unwrap();
    let mins = *traj.independent_min_durations();
    assert_eq!(traj.duration(), mins[0]);
    assert_eq!(traj.profiles()[1].duration(), mins[1]);

    input.synchronization = Synchronization::TimeIfNecessary;
    let traj = calculate(&input).unwrap();
    assert_eq!(traj.profiles()[1].duration(), mins[1]);
}

#[test]
fn phase_synchronization_gives_a_straight_line() {
    let mut input = Input::<2>::with_limits([1.0, 1.0], [1.0, 1.0], [1.0, 1.0]);
    input.target_position = [2.0, 1.0];
    input.synchronization = Synchronization::Phase;
    let traj = calculate(&input).unwrap();
    assert_eq!(traj.profiles()[1].kind(), ProfileKind::PhaseSynchronized);
    for k in 0..=20 {
        let s = traj.state_at(traj.duration() * k as f64 / 20.0);
        assert!((s[0].position - 2.0 * s[1].position).abs() < 1e-12);
    }
}

#[test]
fn velocity_interface_reaches_target_velocity() {
    let mut input = Input::<1>::with_limits([1.0], [2.0], [4.0]);
    input.control_interface = ControlInterface::Velocity;
    input.current_velocity = [-1.0];
    input.target_velocity = [3.0]; // velocity limits are ignored by this interface
    input.target_acceleration = [0.5];
    let traj = calculate(&input).unwrap();
    let end = traj.state_at(traj.duration())[0];
    assert_eq!((end.velocity, end.acceleration), (3.0, 0.5));
    assert!(traj.duration() > 0.0);
}

#[test]
fn invalid_inputs_are_typed_errors() {
    let mut input = unit_limits::<2>();
    input.max_jerk = [1.0, f64::NAN];
    assert_eq!(
        calculate(&input).unwrap_err(),
        TrajectoryError::InvalidInput {
            axis: 1,
            reason: InvalidReason::NotFinite(InputField::MaxJerk)
        }
    );
    let mut input = unit_limits::<2>();
    input.max_acceleration = [-1.0, 1.0];
    assert_eq!(
        calculate(&input).unwrap_err(),
        TrajectoryError::InvalidInput {
            axis: 0,
            reason: InvalidReason::NegativeMaximum(InputField::MaxAcceleration)
        }
    );
    let mut input = unit_limits::<1>();
    input.target_velocity = [1.5];
    let e = calculate(&input).unwrap_err();
    assert_eq!(e.code(), -100);
    assert_eq!(
        e,
        TrajectoryError::InvalidInput {
            axis: 0,
            reason: InvalidReason::TargetAboveMaximum(InputField::TargetVelocity)
        }
    );
    let mut input = unit_limits::<1>();
    input.target_velocity = [0.9];
    input.target_acceleration = [-0.9]; // 0.9 + 0.81/2 > 1
    assert_eq!(
        calculate(&input).unwrap_err(),
        TrajectoryError::InvalidInput {
            axis: 0,
            reason: InvalidReason::TargetInevitablyAboveMaxVelocity
        }
    );
    let mut input = unit_limits::<1>();
    input.minimum_duration = Some(-1.0);
    assert_eq!(
        calculate(&input).unwrap_err(),
        TrajectoryError::InvalidOption(InvalidOption::MinimumDuration)
    );
    // Zero limits that make the target unreachable.
    let mut input = unit_limits::<1>();
    input.max_acceleration = [0.0];
    input.target_position = [1.0];
    assert_eq!(
        calculate(&input).unwrap_err(),
        TrajectoryError::ZeroLimits { axis: 0 }
    );
    let mut input = unit_limits::<1>();
    input.max_velocity = [0.0];
    input.target_position = [1.0];
    assert_eq!(calculate(&input).unwrap_err().code(), -110);
    // Errors display with the axis.
    let text = format!("{}", TrajectoryError::ZeroLimits { axis: 3 });
    assert!(text.contains("axis 3"), "{text}");
}

#[test]
fn synchronized_duration_cap() {
    let mut input = unit_limits::<2>();
    input.target_position = [17299.9, 1.0];
    assert!(matches!(
        calculate(&input),
        Err(TrajectoryError::DurationTooLong { .. })
    ));
    // A single axis is not synchronized and not capped.
    let mut input = unit_limits::<1>();
    input.target_position = [17299.9];
    assert!(calculate(&input).unwrap().duration() > 7600.0);
}

#[test]
fn current_state_outside_limits_is_braked() {
    let mut input = unit_limits::<1>();
    input.current_velocity = [2.5];
    input.current_acceleration = [1.5];
    input.target_position = [10.0];
    let traj = calculate(&input).unwrap();
    let p = traj.profile(0).unwrap();
    assert!(p.brake().count() > 0);
    // After the brake every sample is inside the limits.
    let t0 = p.brake_duration();
    for k in 0..=200 {
        let t = t0 + (traj.duration() - t0) * k as f64 / 200.0;
        let s = traj.state_at(t)[0];
        assert!(
            s.velocity.abs() <= 1.0 + 1e-9 && s.acceleration.abs() <= 1.0 + 1e-9,
            "{t}: {s:?}"
        );
    }
}

#[test]
fn online_generator_follows_and_replans() {
    let period = 0.001;
    let mut input = Input::<2>::with_limits([1.0, 1.0], [2.0, 2.0], [10.0, 10.0]);
    input.target_position = [0.5, -0.2];
    let mut otg = OnlineGenerator::<2>::new(period).unwrap();
    let mut steps = 0;
    // Half way, change the target: the generator re-plans from its current state.
    loop {
        let status = otg.step(&mut input).unwrap();
        steps += 1;
        if steps == 300 {
            input.target_position = [0.1, 0.4];
        }
        if status == OnlineStatus::Finished {
            break;
        }
        assert!(steps < 100_000);
    }
    assert_eq!(otg.replans(), 2);
    assert!((input.current_position[0] - 0.1).abs() < 1e-9);
    assert!((input.current_position[1] - 0.4).abs() < 1e-9);
    assert!(input.current_velocity.iter().all(|v| v.abs() < 1e-9));
    assert_eq!(
        OnlineGenerator::<1>::new(0.0).unwrap_err(),
        TrajectoryError::InvalidOption(InvalidOption::Period)
    );
}

#[test]
fn online_generator_is_continuous_across_a_replan() {
    let mut input = Input::<1>::with_limits([1.0], [2.0], [10.0]);
    input.target_position = [1.0];
    let mut otg = OnlineGenerator::<1>::new(0.001).unwrap();
    let mut prev = input.current_velocity[0];
    for k in 0..2000 {
        if k == 400 {
            input.target_position = [-1.0];
        }
        otg.step(&mut input).unwrap();
        let v = input.current_velocity[0];
        // |Δv| per cycle is bounded by the acceleration limit.
        assert!(
            (v - prev).abs() <= 2.0 * 0.001 + 1e-12,
            "cycle {k}: {prev} -> {v}"
        );
        prev = v;
    }
}

#[test]
fn velocity_interface_blocked_intervals_are_decided_by_feasibility() {
    // Axis 0 has three extremal profiles (0.0580, 0.0686, 0.3468 s) with one blocked interval
    // (0.0686, 0.3468): the duration of axis 1 (0.0597 s) is feasible for it. Reference (ruckig
    // 0.19.4): 0.05972755000431295.
    let mut input = Input::<3>::with_limits(
        [2.51795, 297.698, 1.48977],
        [74.1521, 66072.0, 10.4141],
        [418.667, 2399060.0, 7995.44],
    );
    input.control_interface = ControlInterface::Velocity;
    input.min_acceleration = Some([-162.819, -66072.0, -41.3266]);
    input.current_velocity = [1.81776, 173.361, 2.69108];
    input.current_acceleration = [-52.4588, -50316.1, 0.0];
    input.target_velocity = [-0.866151, 546.499, 2.44682];
    input.target_acceleration = [-34.5047, 0.0, -13.4427];
    let traj = calculate(&input).unwrap();
    assert!(
        (traj.duration() - 0.05972755000431295).abs() < 1e-12,
        "{}",
        traj.duration()
    );
    for (i, s) in traj.state_at(traj.duration()).iter().enumerate() {
        assert_eq!(
            (s.velocity, s.acceleration),
            (input.target_velocity[i], input.target_acceleration[i])
        );
    }
}

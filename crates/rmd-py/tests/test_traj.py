"""plan: rmd-traj's trajectories as NumPy arrays."""

from __future__ import annotations

import numpy as np
import pytest

import rmd_rt


def test_three_axes_arrive_together_within_their_limits():
    v, a, j = [2.0, 1.5, 1.0], [8.0, 6.0, 4.0], [80.0, 60.0, 40.0]
    traj = rmd_rt.plan(
        [0.0, -0.5, 0.3], [1.0, 0.7, -0.2], v, a, j, current_velocity=[-0.5, 0.0, 0.0]
    )
    assert traj.dofs == 3 and traj.duration > 0
    s = traj.sample_every(0.001)
    n = len(s["time"])
    for key in ("position", "velocity", "acceleration", "jerk"):
        assert s[key].shape == (n, 3) and s[key].dtype == np.float64
    assert s["time"][0] == 0.0 and s["time"][-1] == pytest.approx(traj.duration)
    np.testing.assert_allclose(s["position"][0], [0.0, -0.5, 0.3], atol=1e-9)
    np.testing.assert_allclose(s["velocity"][0], [-0.5, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(s["position"][-1], [1.0, 0.7, -0.2], atol=1e-6)
    np.testing.assert_allclose(s["velocity"][-1], 0.0, atol=1e-6)
    assert np.all(np.abs(s["velocity"]) <= np.array(v) + 1e-6)
    assert np.all(np.abs(s["acceleration"]) <= np.array(a) + 1e-6)
    # The position is the integral of the velocity (trapezoids at 1 ms).
    integral = s["position"][0] + np.cumsum(
        (s["velocity"][1:] + s["velocity"][:-1]) / 2 * np.diff(s["time"])[:, None], axis=0
    )
    np.testing.assert_allclose(integral[-1], s["position"][-1], atol=1e-3)
    assert traj.limiting_axis in (0, 1, 2)
    assert max(traj.independent_min_durations) == pytest.approx(traj.duration, rel=1e-6)


def test_sample_at_given_times():
    traj = rmd_rt.plan([0.0], [1.0], [1.0], [1.0], [1.0])
    s = traj.sample(np.array([0.0, traj.duration / 2, traj.duration]))
    assert s["position"].shape == (3, 1)
    assert s["position"][1, 0] == pytest.approx(0.5, abs=1e-9)  # symmetric profile


def test_bad_inputs_are_trajectory_errors():
    with pytest.raises(rmd_rt.TrajectoryError, match="expected 2"):
        rmd_rt.plan([0.0, 0.0], [1.0], [1.0, 1.0], [1.0, 1.0], [1.0, 1.0])
    with pytest.raises(rmd_rt.TrajectoryError):
        rmd_rt.plan([0.0], [1.0], [-1.0], [1.0], [1.0])
    with pytest.raises(rmd_rt.TrajectoryError, match="1..=16"):
        rmd_rt.plan([0.0] * 17, [1.0] * 17, [1.0] * 17, [1.0] * 17, [1.0] * 17)
    with pytest.raises(rmd_rt.TrajectoryError, match="synchronization"):
        rmd_rt.plan([0.0], [1.0], [1.0], [1.0], [1.0], synchronization="soon")

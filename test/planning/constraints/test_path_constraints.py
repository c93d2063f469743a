"""
Constraint objects of the path-velocity step: every limit held at the grid points.

The profile of :class:`PathLimits` is checked here against the physical
quantities computed in the test: joint torques of a two-link arm in a
vertical plane (its closed-form dynamics written below, not the planner's)
and the speed of its tip.
"""

import os

from example_counts import examples
from hypothesis import assume, given, settings, strategies as st
import numpy as np
import pytest
from splines445_ros.planning import plan
from splines445_ros.planning.constraints import (GravityOverload, GriddedPath, JointAcceleration,
                                                 JointTorque, JointVelocity, ToolSpeed)
from splines445_ros.planning.path_following.path_timing import _RoundedTiming
from splines445_ros.planning.speed_profile.path_velocity import PathLimits, traversal_times

EXAMPLES = int(os.environ.get('SPLINES445_PROPERTY_EXAMPLES', str(examples(25))))
LINKS = (0.5, 0.4)          # m
MASSES = (3.0, 2.0)         # kg
CENTRES = (0.25, 0.2)       # m from each joint
INERTIAS = (0.06, 0.03)     # kg m^2 about each link's centre
GRAVITY = 9.81


def two_link_torques(q, qd, qdd):
    """Return tau = M(q) qdd + C(q, qd) qd + g(q) of the planar two-link arm, (N, 2) each."""
    (l1, _), (m1, m2), (c1, c2), (i1, i2) = LINKS, MASSES, CENTRES, INERTIAS
    cos2, sin2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    m11 = m1 * c1**2 + m2 * (l1**2 + c2**2 + 2 * l1 * c2 * cos2) + i1 + i2
    m12 = m2 * (c2**2 + l1 * c2 * cos2) + i2
    m22 = m2 * c2**2 + i2
    h = -m2 * l1 * c2 * sin2
    g1 = ((m1 * c1 + m2 * l1) * np.cos(q[:, 0]) + m2 * c2 * np.cos(q[:, 0] + q[:, 1])) * GRAVITY
    g2 = m2 * c2 * np.cos(q[:, 0] + q[:, 1]) * GRAVITY
    tau1 = m11 * qdd[:, 0] + m12 * qdd[:, 1] + h * (2 * qd[:, 0] * qd[:, 1] + qd[:, 1]**2) + g1
    tau2 = m12 * qdd[:, 0] + m22 * qdd[:, 1] - h * qd[:, 0]**2 + g2
    return np.stack([tau1, tau2], axis=1)


def tip_velocity(q, qd):
    """Velocity of the arm's tip (N, 2)."""
    l1, l2 = LINKS
    s1, s12 = np.sin(q[:, 0]), np.sin(q[:, 0] + q[:, 1])
    c1, c12 = np.cos(q[:, 0]), np.cos(q[:, 0] + q[:, 1])
    return np.stack([-l1 * s1 * qd[:, 0] - l2 * s12 * (qd[:, 0] + qd[:, 1]),
                     l1 * c1 * qd[:, 0] + l2 * c12 * (qd[:, 0] + qd[:, 1])], axis=1)


def test_the_two_link_dynamics_conserve_energy():
    """The test's own dynamics: with no torque, kinetic plus potential energy stays constant."""
    (l1, _), (m1, m2), (c1, c2), (i1, i2) = LINKS, MASSES, CENTRES, INERTIAS

    def energy(q, qd):
        p1 = c1 * np.array([np.cos(q[0]), np.sin(q[0])])
        v1 = c1 * qd[0] * np.array([-np.sin(q[0]), np.cos(q[0])])
        p2 = l1 * np.array([np.cos(q[0]), np.sin(q[0])]) + c2 * np.array(
            [np.cos(q[0] + q[1]), np.sin(q[0] + q[1])])
        v2 = l1 * qd[0] * np.array([-np.sin(q[0]), np.cos(q[0])]) + c2 * (qd[0] + qd[1]) * \
            np.array([-np.sin(q[0] + q[1]), np.cos(q[0] + q[1])])
        kinetic = 0.5 * (m1 * v1 @ v1 + m2 * v2 @ v2 + i1 * qd[0]**2 + i2 * (qd[0] + qd[1])**2)
        return kinetic + GRAVITY * (m1 * p1[1] + m2 * p2[1])

    def acceleration(q, qd):
        # Solve M qdd = -(c + g) column by column of the inverse dynamics.
        rest = two_link_torques(q[None], qd[None], np.zeros((1, 2)))[0]
        mass = np.stack([two_link_torques(q[None], np.zeros((1, 2)), e[None])[0]
                         - two_link_torques(q[None], np.zeros((1, 2)), np.zeros((1, 2)))[0]
                         for e in np.eye(2)], axis=1)
        return np.linalg.solve(mass, -rest)

    q, qd, dt = np.array([0.3, 1.1]), np.array([1.0, -2.0]), 1e-4
    start = energy(q, qd)
    for _ in range(2000):     # classic Runge-Kutta on (q, qd)
        k1 = qd, acceleration(q, qd)
        k2 = qd + dt / 2 * k1[1], acceleration(q + dt / 2 * k1[0], qd + dt / 2 * k1[1])
        k3 = qd + dt / 2 * k2[1], acceleration(q + dt / 2 * k2[0], qd + dt / 2 * k2[1])
        k4 = qd + dt * k3[1], acceleration(q + dt * k3[0], qd + dt * k3[1])
        q = q + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        qd = qd + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    assert abs(energy(q, qd) - start) < 1e-8 * abs(start) + 1e-9


def random_path(rng, n_waypoints=5):
    """Return a 555 spline through random waypoints of the arm, in its own time s, gridded."""
    points = np.cumsum(rng.uniform(-0.8, 0.8, (n_waypoints, 2)), axis=0)
    spline = plan(points, '555', 'fixed', durations=np.ones(n_waypoints - 1))
    s = np.linspace(0.0, n_waypoints - 1.0, 40 * (n_waypoints - 1) + 1)
    return GriddedPath.of_ppoly(spline.ppoly, s)


def held_at_grid_points(path, x):
    """Joint velocity, acceleration and the path acceleration u per step, from the profile."""
    u = np.diff(x) / (2.0 * np.diff(path.s))
    qd = path.first * np.sqrt(x)[:, None]
    qdd = path.first[:-1] * u[:, None] + path.second[:-1] * x[:-1, None]
    return qd, qdd


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_torque_limits_hold_at_every_grid_point(seed):
    rng = np.random.default_rng(seed)
    path = random_path(rng)
    zero = np.zeros_like(path.positions)
    gravity = np.max(np.abs(two_link_torques(path.positions, zero, zero)), axis=0)
    limit = gravity * rng.uniform(1.2, 3.0, 2) + rng.uniform(1.0, 5.0, 2)
    constraints = (JointVelocity([3.0, 3.0]), JointTorque(limit, two_link_torques))
    x = PathLimits(path, constraints).profile(np.ones(path.s.size))
    assert x[0] == 0.0 and x[-1] == 0.0 and np.all(np.isfinite(x)) and np.all(x >= 0.0)
    qd, qdd = held_at_grid_points(path, x)
    tau = two_link_torques(path.positions[:-1], qd[:-1], qdd)
    assert np.all(np.abs(tau) <= limit * (1 + 1e-9))
    assert np.all(np.abs(qd) <= 3.0 * (1 + 1e-9))
    # Time-optimal: some torque (or the velocity) binds on most steps.
    ratio = np.maximum(np.max(np.abs(tau) / limit, axis=1), np.max(np.abs(qd[:-1]) / 3.0, axis=1))
    assert np.median(ratio) > 0.99


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_interpolated_torque_rows_hold_at_both_ends_of_every_step(seed):
    """
    ``JointTorque(..., interpolated=True)``: each step's path acceleration holds at its end too.

    Collocated rows hold the torque at grid point i with step i's ``u``
    only; at grid point i + 1 the same ``u`` (with x_{i + 1}) may pass the
    limit, which the interpolated rows forbid.  The torques are computed
    here from the test's own dynamics at both ends of every step.
    """
    rng = np.random.default_rng(seed)
    path = random_path(rng)
    zero = np.zeros_like(path.positions)
    gravity = np.max(np.abs(two_link_torques(path.positions, zero, zero)), axis=0)
    limit = gravity * rng.uniform(1.2, 3.0, 2) + rng.uniform(1.0, 5.0, 2)
    constraints = (JointVelocity([3.0, 3.0]),
                   JointTorque(limit, two_link_torques, interpolated=True))
    x = PathLimits(path, constraints).profile(np.ones(path.s.size))
    assert x[0] == 0.0 and x[-1] == 0.0 and np.all(np.isfinite(x)) and np.all(x >= 0.0)
    assert np.isfinite(traversal_times(x, np.diff(path.s))[-1])
    u = np.diff(x) / (2.0 * np.diff(path.s))
    for at in (slice(None, -1), slice(1, None)):     # each step's start, then its end
        qd = path.first[at] * np.sqrt(x[at])[:, None]
        qdd = path.first[at] * u[:, None] + path.second[at] * x[at][:, None]
        assert np.all(np.abs(two_link_torques(path.positions[at], qd, qdd)) <= limit * (1 + 1e-9))


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_tool_speed_holds_at_every_grid_point_and_binds(seed):
    rng = np.random.default_rng(seed)
    path = random_path(rng)
    speed = rng.uniform(0.05, 0.5)

    def tangent(p):
        return tip_velocity(p.positions, p.first)

    constraints = (JointVelocity([3.0, 3.0]), JointAcceleration([20.0, 20.0]),
                   ToolSpeed(speed, tangent))
    x = PathLimits(path, constraints).profile(np.ones(path.s.size))
    qd, _ = held_at_grid_points(path, x)
    tip = np.linalg.norm(tip_velocity(path.positions, qd), axis=1)
    assert np.all(tip <= speed * (1 + 1e-9))
    assume(np.all(np.linalg.norm(tangent(path), axis=1)[1:-1] > 1e-3))
    # Slow enough for the joints: the tool speed binds over most of the path.
    assert np.mean(tip > 0.99 * speed) > 0.5


def test_torque_of_a_constant_inertia_is_an_acceleration_limit():
    """A single joint with inertia I and no gravity: tau <= T is exactly qdd <= T / I."""
    inertia, torque = 0.7, 2.1
    s = np.linspace(0.0, 1.0, 401)
    path = GriddedPath(s, 1.5 * s[:, None], np.full((401, 1), 1.5), np.zeros((401, 1)))

    def dynamics(q, qd, qdd):
        return inertia * qdd

    x_torque = PathLimits(path, (JointVelocity([2.0]), JointTorque([torque], dynamics)))
    x_accel = PathLimits(path, (JointVelocity([2.0]), JointAcceleration([torque / inertia])))
    ones = np.ones(401)
    np.testing.assert_allclose(x_torque.profile(ones), x_accel.profile(ones), rtol=1e-12)
    # And its duration is the trapezoid's: 1.5 rad at 2 rad/s and 3 rad/s^2.
    expected = 1.5 / 2.0 + 2.0 / (torque / inertia)
    total = traversal_times(x_torque.profile(ones), np.diff(s))[-1]
    assert expected <= total <= expected * (1 + 1e-3)


def test_a_pose_gravity_alone_overloads_is_refused_with_the_joint():
    rng = np.random.default_rng(3)
    path = random_path(rng)
    zero = np.zeros_like(path.positions)
    gravity = np.max(np.abs(two_link_torques(path.positions, zero, zero)), axis=0)
    limit = np.array([gravity[0] * 2.0, gravity[1] * 0.9])
    with pytest.raises(GravityOverload) as error:
        PathLimits(path, (JointVelocity([3.0, 3.0]), JointTorque(limit, two_link_torques)))
    assert error.value.joint == 1
    assert abs(error.value.torque) > limit[1]
    assert 'joint 1' in str(error.value)


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_a_rounded_span_keeps_its_ends_and_turns_acceleration_jumps_into_ramps(seed):
    """
    Tool lines' corner rounding (path_timing._RoundedTiming) on a ramp-cap-ramp span.

    The plain profile accelerates at ``a`` to a cap and brakes at ``a`` to
    rest, its acceleration jumping by ``a`` at both corners of the cap.
    The rounded position keeps the span's ends (time and rest), is
    increasing, is inverted by time_at (in position), and away from the stops its
    acceleration (second differences here) moves by at most about
    ``a dt / W`` per sample of ``dt`` instead of jumping by ``a``.
    """
    rng = np.random.default_rng(seed)
    a, v = rng.uniform(1.0, 5.0), rng.uniform(0.2, 1.0)
    length = v * v / a + rng.uniform(0.5, 2.0) * v       # reaches the cap
    s = np.linspace(0.0, length, 801)
    x = np.minimum(np.minimum(2.0 * a * s, 2.0 * a * (length - s)), v * v)
    times = traversal_times(x, np.diff(s))
    width = rng.uniform(0.05, 0.2)
    rounded = _RoundedTiming(times, x, s, width)
    assert rounded.duration == times[-1]
    assert rounded.position_at(np.array([0.0]))[0] == 0.0
    assert rounded.position_at(np.array([times[-1]]))[0] == pytest.approx(length, abs=1e-12)
    dt = 1e-4
    t = np.arange(0.0, times[-1], dt)
    p = rounded.position_at(t)
    assert np.all(np.diff(p) >= -1e-12)
    inner = (p > 1e-3 * length) & (p < (1 - 1e-3) * length)
    np.testing.assert_allclose(rounded.position_at(rounded.time_at(p[inner])), p[inner],
                               atol=1e-7 * length)
    # Away from the stops (beyond one window) the rounded acceleration is a ramp.
    acc = np.diff(p, 2) / dt ** 2
    away = (t[1:-1] > width) & (t[1:-1] < times[-1] - width)
    jumps = np.abs(np.diff(acc))[away[1:] & away[:-1]]
    assert np.max(jumps) <= 1.2 * a * dt / width + 1e-6 * a

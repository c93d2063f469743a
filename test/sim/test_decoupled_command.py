"""
The dynamic arm's decoupled command, checked against its definition on a real arm (the Panda).

Unsaturated, the command is ``forward + M diag(M_0)^-1 feedback`` (M the inertia
matrix at the commanded pose, M_0 the one at the initial pose): with it the
arm's acceleration deviation ``M^-1 (command - forward)`` is each joint's own
loop's ``feedback / diag(M_0)``.  Where that command exceeds a limit, it is the
command within the limits nearest to it in the inertia's norm, which is so
exactly when (the optimality conditions of that convex problem) every joint
inside its limits gets its own loop's acceleration and every joint at a limit
is held back by it, never pushed beyond what its loop asks.  The test
computes the deviation from MuJoCo's inertia matrix, read here, not from the
arm's code.
"""

import itertools
import types

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from splines445_ros.sim.dynamic_sim import DynamicArm
from splines445_ros.tools import vendor_robots as vr
from test_model_drive_settling import dynamic_arm, inertia_matrix, PANDA, PANDA_COUPLED_POSE

pytest.importorskip('mujoco')

_ARM = {}


def panda():
    """Return (config, DynamicArm) of the Panda, built once."""
    if not _ARM:
        _ARM['arm'] = dynamic_arm(vr.robot_file(PANDA[0]), PANDA[1])
    return _ARM['arm']


@settings(max_examples=examples(60), deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), spread=st.sampled_from([0.1, 0.5, 3.0]))
def test_every_unsaturated_joint_gets_its_own_loops_acceleration(seed, spread):
    config, arm = panda()
    rng = np.random.default_rng(seed)
    n = arm.n_joints
    pose = np.array(PANDA_COUPLED_POSE) + rng.uniform(-0.5, 0.5, n)
    design = np.diag(inertia_matrix(arm, config.initial_positions))
    inertia = inertia_matrix(arm, pose)
    arm.feedforward(pose, np.zeros(n), np.zeros(n))    # the commanded pose
    limits = arm.limits
    forward = rng.uniform(-0.8, 0.8, n) * limits
    feedback = rng.normal(0.0, spread, n) * limits
    command, saturated = arm.decoupled_command(forward, feedback)
    wanted = feedback / design
    deviation = np.linalg.solve(inertia, command - forward)
    assert np.all(np.abs(command) <= limits * (1 + 1e-12))
    free = np.abs(command) < limits * (1 - 1e-12)
    scale = np.max(np.abs(wanted))
    np.testing.assert_allclose(deviation[free], wanted[free], rtol=1e-7, atol=1e-9 * scale)
    # At a limit, the limit holds the joint back from what its loop asks, never pushes
    # it beyond (the optimality condition of the nearest command within the limits).
    held = ~free
    assert np.all(np.sign(command[held]) * (deviation[held] - wanted[held]) <= 1e-9 * scale)
    if not saturated:
        np.testing.assert_allclose(command, forward + inertia @ wanted, rtol=1e-9, atol=1e-9)
        assert np.all(free)
    else:
        assert np.any(np.abs(forward + inertia @ wanted) > limits) and np.any(held)


def kicked_at_the_coupled_pose(limited, kick, margin=5.0, steps=2000):
    """
    Hold the Panda at its coupled pose for ``steps``, the ``limited`` joints kicked by ``kick``.

    Their limits are ``margin`` above what holds them there.  Returns the held
    references (steps, n), the log and the lowered limits.
    """
    config, arm = panda()
    n = arm.n_joints
    pose = np.array(PANDA_COUPLED_POSE)
    hold = arm.feedforward(pose, np.zeros(n), np.zeros(n))
    limits = np.array(config.torque_limits, dtype=float)
    lowered = limits.copy()
    lowered[limited] = np.abs(hold[limited]) + margin
    arm.limits = lowered
    try:
        arm.set_state(pose, np.eye(n)[limited].sum(axis=0) * kick)
        held = np.tile(pose, (steps, 1))
        log = arm.run(held, np.zeros_like(held), np.zeros_like(held))
    finally:
        arm.limits = limits
    return held, log, lowered


def test_two_coupled_joints_at_their_limits_come_to_rest_without_chatter():
    """Joints 1 and 3, nearly aligned, both 5 N m above what holds them, kicked together."""
    held, log, lowered = kicked_at_the_coupled_pose([0, 2], 0.3)
    steps = len(held)
    assert log['saturated'].any()
    jumps = np.abs(np.diff(log['command'], axis=0)).max(axis=0)
    assert np.all(jumps < lowered), jumps      # never from one limit to the other
    error = np.abs(held - log['position']).max(axis=0)
    assert np.all(error[[1, 3, 4, 5, 6]] < 1e-3), error
    assert np.abs(log['velocity'][-steps // 4:]).max() < 1e-4


def test_a_saturated_joint_does_not_drag_the_others_or_make_them_chatter():
    """
    Kicked at the coupled pose with joint 1's limit just above what holds it, the others stay.

    Clipping the decoupled command alone let joints 1 and 3 swing 0.3 rad; leaving
    the saturated joint's terms out of the others' commands made a coupled
    pair's commands jump between their limits from one step to the next.
    """
    held, log, lowered = kicked_at_the_coupled_pose([0], 0.3)
    steps = len(held)
    limits = np.array(panda()[0].torque_limits, dtype=float)
    assert log['saturated'].any()
    error = np.abs(held - log['position']).max(axis=0)
    assert np.all(error[1:] < 1e-3), error
    jumps = np.abs(np.diff(log['command'], axis=0)).max(axis=0)
    assert np.all(jumps < 0.1 * limits), jumps
    assert np.abs(log['velocity'][-steps // 4:]).max() < 1e-4


def enumerated(inertia, forward, wanted, limits):
    """Return the optimum found by its conditions over every free / lower / upper (3^n)."""
    n = len(forward)
    for held in itertools.product((-1.0, 0.0, 1.0), repeat=n):
        held = np.array(held)
        at, free = held != 0.0, held == 0.0
        tau = np.where(at, held * limits, 0.0)
        moved = np.linalg.solve(inertia[np.ix_(at, at)], tau[at] - forward[at]
                                - inertia[np.ix_(at, free)] @ wanted[free]) if at.any() else []
        tau[free] = (forward[free] + inertia[np.ix_(free, free)] @ wanted[free]
                     + inertia[np.ix_(free, at)] @ moved)
        scale = 1e-9 * (1.0 + np.max(np.abs(wanted)))
        if (np.all(np.abs(tau[free]) <= limits[free] * (1 + 1e-12))
                and np.all(held[at] * (moved - wanted[at]) <= scale)):
            return tau
    raise AssertionError('no assignment meets the conditions')


def solved(inertia, forward, wanted, limits):
    """Call DynamicArm.decoupled_command on an arm whose inertia is ``inertia`` everywhere."""
    design = np.diag(inertia).copy()
    arm = types.SimpleNamespace(coupling=lambda: inertia / design[None, :],
                                _design_inertia=design, limits=limits)
    return DynamicArm.decoupled_command(arm, forward, wanted * design)[0]


def test_an_ill_conditioned_inertia_still_gets_the_nearest_command():
    """helper-84's case (condition 1.5e3): the steps cycled and sent joint 2 the wrong way."""
    inertia = np.array([[319.36642, 323.454616, -140.123893],
                        [323.454616, 599.927746, -755.815771],
                        [-140.123893, -755.815771, 1457.765736]])
    limits = np.array([1.829572, 3.451719, 0.838074])
    forward = np.array([2.67945, 4.473882, -0.300886])
    wanted = np.array([0.004191, 0.003457, 0.000598])
    np.testing.assert_allclose(solved(inertia, forward, wanted, limits),
                               enumerated(inertia, forward, wanted, limits), atol=1e-7)


@settings(max_examples=examples(100), deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), n=st.integers(2, 5),
       condition=st.sampled_from([10.0, 1e3, 2e3, 1e4]))
def test_the_command_is_the_enumerated_optimum_on_random_inertias(seed, n, condition):
    rng = np.random.default_rng(seed)
    basis, _ = np.linalg.qr(rng.normal(size=(n, n)))
    inertia = basis @ np.diag(np.exp(rng.uniform(0.0, np.log(condition), n))) @ basis.T
    limits = rng.uniform(0.5, 5.0, n)
    forward = rng.uniform(-1.5, 1.5, n) * limits
    wanted = np.linalg.solve(inertia, rng.normal(0.0, 2.0, n) * limits)
    np.testing.assert_allclose(solved(inertia, forward, wanted, limits),
                               enumerated(inertia, forward, wanted, limits),
                               atol=1e-6 * np.max(limits))

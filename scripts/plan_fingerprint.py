#!/usr/bin/env python3
"""
Fingerprint of the plans of 36 seeded random requests: a refactoring must not change it.

Issue 37 moves modules without changing behaviour.  This script plans the
same requests through the node's request layer (the planner config as the
parameters give it): joint-space requests of every method and timing, 555
optimal with a ``vibration_frequency``, planar tool requests with a tool
speed, UR5 tool requests, and UR5 and Panda requests with torque limits and a
payload.  It prints one SHA-256 per request, of its breakpoints and
coefficients (``Trajectory.ppoly.x`` and ``.c``, bytes as computed), and one
of them all.  Run it before and after a change and compare the output::

    source install/setup.bash && python scripts/plan_fingerprint.py > before.txt
"""

import hashlib
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..'))

from splines445_ros.service.model_planning import (  # noqa: E402
    build_robot_setup, plan_model_tool_request)
from splines445_ros.service.parameter_table import not_set_values  # noqa: E402
from splines445_ros.service.planner_config import PlannerConfig  # noqa: E402
from splines445_ros.service.request_planning import (  # noqa: E402
    plan_request, plan_tool_request, WaypointRequest)
from splines445_ros.tools.vendor_robots import (  # noqa: E402
    PANDA_ARM_JOINTS, PANDA_READY, panda_urdf, UR5_JOINTS, UR5_READY, ur5_urdf)

SEED = 37
CONFIG = os.path.join(HERE, '..', 'config')


def digest(traj):
    """Return the SHA-256 of a trajectory's breakpoints and coefficients."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(traj.ppoly.x).tobytes())
    h.update(np.ascontiguousarray(traj.ppoly.c).tobytes())
    return h.hexdigest()


def joint_request(rng, n_joints, ready=None, spread=1.0):
    """Return a rest-to-rest WaypointRequest of 3-7 random waypoints."""
    n = int(rng.integers(3, 8))
    base = np.zeros(n_joints) if ready is None else np.asarray(ready, dtype=float)
    points = base + spread * rng.uniform(-1.0, 1.0, (n, n_joints))
    zeros = np.zeros(n_joints)
    return WaypointRequest(points, zeros, zeros, zeros, zeros, None)


def joint_cases(rng):
    """Yield (label, trajectory) of joint-space requests, vibration_frequency included."""
    for k, (method, timing) in enumerate([(m, t) for m in ('434', '445', '555')
                                          for t in ('uniform', 'optimal')] * 3):
        n = int(rng.integers(3, 8))
        a = rng.uniform(5.0, 15.0, n)
        config = PlannerConfig.from_values({
            'joint_names': tuple(f'j{i}' for i in range(n)), 'method': method,
            'timing': timing, 'max_velocity': tuple(rng.uniform(1.0, 3.0, n)),
            'max_acceleration': tuple(a), 'max_jerk': tuple(20.0 * a)})
        yield f'joint {k} {method}/{timing}', plan_request(config, joint_request(rng, n))
    for k in range(6):
        n = int(rng.integers(3, 8))
        a = rng.uniform(5.0, 15.0, n)
        config = PlannerConfig.from_values({
            'joint_names': tuple(f'j{i}' for i in range(n)), 'method': '555',
            'timing': 'optimal', 'max_velocity': tuple(rng.uniform(1.0, 3.0, n)),
            'max_acceleration': tuple(a), 'max_jerk': tuple(20.0 * a),
            'vibration_frequency': float(rng.uniform(3.0, 8.0))})
        yield f'vibration {k}', plan_request(config, joint_request(rng, n))


def planar_tool_cases(rng):
    """Yield planar 3-DOF tool requests, refined and timed along the lines."""
    for k, (method, timing, speed) in enumerate([('555', 'uniform', 0.0),
                                                 ('555', 'optimal', 0.0),
                                                 ('555', 'optimal', 0.3),
                                                 ('555', 'optimal', 0.5)]):
        config = PlannerConfig.from_values({
            'kinematics': 'planar_3dof', 'method': method, 'timing': timing,
            'max_jerk': (200.0, 200.0, 200.0), 'max_path_deviation': 1e-3,
            'max_tool_speed': speed})
        n = int(rng.integers(3, 6))
        radius = rng.uniform(0.8, 1.6, n)
        angle = rng.uniform(-0.8, 0.8, n)
        poses = np.column_stack([radius * np.cos(angle), radius * np.sin(angle),
                                 rng.uniform(-0.5, 0.5, n)])
        yield f'planar tool {k} {method}/{timing} v={speed}', \
            plan_tool_request(config, poses).trajectory


def model_config(urdf, limits_file, **values):
    """Return a kinematics "model" PlannerConfig of a vendor arm."""
    return PlannerConfig.from_values(dict(not_set_values(PlannerConfig), **{
        'kinematics': 'model', 'model_file': urdf, 'joint_limits_file': limits_file,
        'method': '555', 'timing': 'optimal'}, **values))  # as declared


def model_cases(rng):
    """Yield UR5 tool requests and UR5 / Panda torque-limited joint requests."""
    ur5_limits = os.path.join(CONFIG, 'ur5_joint_limits.yaml')
    panda_limits = os.path.join(CONFIG, 'panda_joint_limits.yaml')
    setup = build_robot_setup(model_config(ur5_urdf(), ur5_limits, tool_frame='tool0',
                                           base_frame='base_link'))
    ready = np.array(UR5_READY)
    for k, speed in enumerate((0.0, 0.1, 0.25, 0.4)):
        config = model_config(ur5_urdf(), ur5_limits, tool_frame='tool0',
                              base_frame='base_link', max_path_deviation=1e-3,
                              max_orientation_deviation=1e-2, max_tool_speed=speed)
        q = ready + rng.uniform(-0.3, 0.3, (int(rng.integers(3, 5)), ready.size))
        poses = np.array([setup.kinematics.forward(row) for row in q])
        path = plan_model_tool_request(setup, poses, ready, config)
        yield f'ur5 tool {k} v={speed}', path.trajectory
    for name, urdf, limits, pose, joints, tool, mass in (
            ('ur5', ur5_urdf(), ur5_limits, UR5_READY, UR5_JOINTS, 'tool0', 5.0),
            ('panda', panda_urdf(), panda_limits, PANDA_READY, PANDA_ARM_JOINTS,
             'panda_hand_tcp', 3.0)):
        for k, payload in enumerate((0.0, mass)):
            config = model_config(urdf, limits, limit_torque=True, payload_mass=payload,
                                  joint_names=joints, tool_frame=tool)
            torque_setup = build_robot_setup(config)
            effective = torque_setup.effective(config)
            request = joint_request(rng, len(pose), pose, 0.6)
            traj = plan_request(effective, request, torque_setup.torque_options(config))
            yield f'{name} torque {k} payload={payload}', traj


def main():
    """Print one digest per request and the digest of all of them."""
    rng = np.random.default_rng(SEED)
    total = hashlib.sha256()
    count = 0
    for cases in (joint_cases, planar_tool_cases, model_cases):
        for label, traj in cases(rng):
            value = digest(traj)
            total.update(value.encode())
            count += 1
            print(f'{value}  {label} ({traj.duration:.6f} s)', flush=True)
    print(f'{total.hexdigest()}  all {count} requests')


if __name__ == '__main__':
    main()

"""
Real robot descriptions this project did not write, from the PyPI package ``example-robot-data``.

Used by the tests, the demo and the benchmarks (a test/demo dependency,
pinned in ``requirements.txt``; not a runtime dependency of the nodes).
Files are located through :mod:`importlib.metadata`, so nothing depends on
where pip put the package.
"""

import importlib.metadata
import os

DISTRIBUTION = 'example-robot-data'
ROBOTS_FOLDER = 'cmeel.prefix/share/example-robot-data/robots'
UR5_URDF = 'ur_description/urdf/ur5_robot.urdf'
PANDA_URDF = 'panda_description/urdf/panda.urdf'
PANDA_ARM_JOINTS = tuple(f'panda_joint{i}' for i in range(1, 8))
UR5_JOINTS = ('shoulder_pan_joint', 'shoulder_lift_joint', 'elbow_joint', 'wrist_1_joint',
              'wrist_2_joint', 'wrist_3_joint')
# A usual UR5 working pose: elbow up, tool pointing down.
UR5_READY = (0.0, -1.9, 1.9, -1.571, -1.571, 0.0)
# The Panda's "ready" pose (franka_ros).
PANDA_READY = (0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785)


def robot_file(relative):
    """Return the absolute path of a file below example-robot-data's ``robots`` folder."""
    try:
        dist = importlib.metadata.distribution(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        raise FileNotFoundError(f'{DISTRIBUTION} is not installed (pip install -r '
                                'requirements.txt)') from None
    path = str(dist.locate_file(f'{ROBOTS_FOLDER}/{relative}'))
    if not os.path.isfile(path):
        raise FileNotFoundError(f'{DISTRIBUTION} has no {relative} (looked at {path})')
    return path


def ur5_urdf():
    """Return the path of the UR5 URDF."""
    return robot_file(UR5_URDF)


def panda_urdf():
    """Return the path of the Franka Panda URDF."""
    return robot_file(PANDA_URDF)

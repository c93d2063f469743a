"""
planner_node's two outputs: message size and conversion / publishing time.

For the paper's example (445 uniform, the node's default method) and
random-walk requests of 100x7 and 1000x7 waypoints x joints (555 uniform,
the method for long paths; v <= 2, a <= 10, fresh seed), the planned
trajectory is turned into the ``joint_trajectory`` message as planner_node
does it, with ``output: sampled`` (every 10 ms, the default sample_period)
and ``output: knots`` (one point per spline knot).  Printed per mode:

* points: number of JointTrajectoryPoints;
* bytes: size of the serialized message (rclpy.serialization, CDR);
* convert [ms]: from the planned Trajectory to the message (sampling or
  knots, then trajectory_to_msg), best of several runs;
* publish [ms]: ``publish()`` on a reliable transient-local publisher (the
  node's QoS) with one matched subscription in the same process, best of
  several runs (serialization included).

Run: ``python benchmarks/bench_output.py`` (``make bench`` runs it too).
"""

import os

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'

import bench_seeds  # noqa: E402, I100
import numpy as np  # noqa: E402, I100
from rclpy.node import Node  # noqa: E402
from rclpy.serialization import serialize_message  # noqa: E402
from splines445_ros.nodes import topics  # noqa: E402
from splines445_ros.nodes.ros_conversions import trajectory_to_msg  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.robot import paper_example as pe  # noqa: E402
from splines445_ros.service.planner_config import PlannerConfig  # noqa: E402
from splines445_ros.service.request_planning import output_samples  # noqa: E402
from splines445_ros.tools.in_process import LocalRos  # noqa: E402
from trajectory_msgs.msg import JointTrajectory  # noqa: E402
from wall_time import best_of  # noqa: E402

OUTPUTS = ('sampled', 'knots')


def cases():
    """Yield (name, joint names, planned Trajectory)."""
    yield ('paper example 12x3, 445', pe.JOINT_NAMES,
           plan(pe.joint_waypoints(), '445', 'uniform', **pe.plan_kwargs()))
    rng = bench_seeds.generator()
    for n_points in (100, 1000):
        waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, 7)), axis=0)
        yield (f'random walk {n_points}x7, 555', [f'joint{i + 1}' for i in range(7)],
               plan(waypoints, '555', 'uniform', max_velocity=np.full(7, 2.0),
                    max_acceleration=np.full(7, 10.0)))


def main():
    """Print the table."""
    with LocalRos() as ros:
        node = ros.add(Node('bench_output', context=ros.context))
        listener = ros.add(Node('bench_output_listener', context=ros.context))
        publisher = node.create_publisher(JointTrajectory, topics.JOINT_TRAJECTORY,
                                          topics.LATCHED)
        listener.create_subscription(JointTrajectory, topics.JOINT_TRAJECTORY,
                                     lambda msg: None, topics.LATCHED)
        if not ros.spin_until(lambda: publisher.get_subscription_count() >= 1, 10.0):
            raise RuntimeError('the subscription did not match')
        print('| request | duration [s] | output | points | bytes | convert [ms] '
              '| publish [ms] |')
        print('|---|---|---|---|---|---|---|')
        for name, joint_names, traj in cases():
            for output in OUTPUTS:
                config = PlannerConfig(joint_names=tuple(joint_names), output=output)
                repeats = 3 if traj.duration > 100.0 else 10

                def convert():
                    return trajectory_to_msg(output_samples(config, traj), joint_names)
                convert_s, msg = best_of(convert, repeats)
                size = len(serialize_message(msg))
                publish_s, _ = best_of(lambda: publisher.publish(msg), repeats)
                ros.spin_for(0.05)  # let the listener take it
                print(f'| {name} | {traj.duration:.2f} | {output} | {len(msg.points)} '
                      f'| {size} | {1e3 * convert_s:.3f} | {1e3 * publish_s:.3f} |')


if __name__ == '__main__':
    main()

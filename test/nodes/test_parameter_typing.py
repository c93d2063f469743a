"""
String parameters as users type them: ``-p method:=434`` arrives as an INTEGER.

Before, such an override killed the node with InvalidParameterTypeException.
Now a number given for a string parameter is stored as its string, and any
other type is rejected by validation with the reason, the node alive.
"""

import os

from diagnostic_msgs.msg import DiagnosticStatus
from node_status import assert_planned
import pytest
from rcl_interfaces.msg import Parameter as ParameterMsg, ParameterType, ParameterValue
from rclpy.parameter import Parameter
from splines445_ros.nodes.arm_sim_node import ArmSimNode
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.node_main import run_node
from splines445_ros.nodes.planner_node import PlannerNode
from splines445_ros.robot import paper_example as pe
from splines445_ros.tools.in_process import InProcessSystem, LocalRos, waypoint_message


def _planner(ros, cli):
    return ros.add(PlannerNode(context=ros.context, cli_args=['--ros-args'] + cli))


@pytest.mark.parametrize('typed', ['434', '445', '555'])
def test_integer_method_on_the_command_line(typed):
    with LocalRos() as ros:
        node = _planner(ros, ['-p', f'method:={typed}'])
        assert node.parameters.config.method == typed
        # Stored as the string, so `ros2 param get` shows what the node uses.
        value = node.get_parameter('method').value
        assert isinstance(value, str) and value == typed


def test_integer_method_in_a_params_file(tmp_path):
    path = os.path.join(tmp_path, 'params.yaml')
    with open(path, 'w', encoding='utf-8') as handle:
        handle.write('planner_node:\n  ros__parameters:\n    method: 434\n')
    with LocalRos() as ros:
        node = _planner(ros, ['--params-file', path])
        assert node.parameters.config.method == '434'


def test_unknown_integer_method_is_a_clear_startup_error():
    with LocalRos() as ros:
        with pytest.raises(ValueError, match=r"method must be one of .*got '999'"):
            PlannerNode(context=ros.context, cli_args=['--ros-args', '-p', 'method:=999'])


def test_set_parameters_with_numbers_and_wrong_types():
    with LocalRos() as ros:
        node = _planner(ros, [])
        ok = node.set_parameters([Parameter('method', value=434)])[0]
        assert ok.successful and node.parameters.config.method == '434'
        assert node.get_parameter('method').value == '434'
        for bad, reason in ((999, "got '999'"), ([1.0, 2.0], 'got (1.0, 2.0)'),
                            (True, 'got True')):
            result = node.set_parameters([Parameter('method', value=bad)])[0]
            assert not result.successful and reason in result.reason, result.reason
            assert node.parameters.config.method == '434'
            assert node.get_parameter('method').value == '434'
        bad_timing = node.set_parameters([Parameter('timing', value=3)])[0]
        assert not bad_timing.successful and 'timing must be one of' in bad_timing.reason


def test_arm_string_parameter_takes_a_number():
    with LocalRos() as ros:
        node = ros.add(ArmSimNode(context=ros.context,
                                  cli_args=['--ros-args', '-p', 'frame_id:=7']))
        assert node.parameters.config.frame_id == '7'
        result = node.set_parameters([Parameter('frame_id', value=['a', 'b'])])[0]
        assert not result.successful and 'frame_id must be a string' in result.reason
        assert node.parameters.config.frame_id == '7'


def test_planner_with_integer_method_serves_requests():
    with InProcessSystem(planner_parameters={'max_jerk': [0.0, 0.0, 0.0]}) as system:
        assert system.set_planner_parameters({'method': 434})[0].successful
        assert not system.set_planner_parameters({'method': 4.5})[0].successful
        status, trajectory = system.request(waypoint_message(
            pe.JOINT_NAMES, pe.joint_waypoints()))
        assert_planned(status)
        assert status_values(status)['method'] == '434'
        assert trajectory is not None


def test_rejected_parameter_updates_are_reported_on_status():
    with InProcessSystem() as system:
        n_planner, n_arm = len(system.planner_status), len(system.arm_status)
        assert not system.set_planner_parameters({'method': 'quintic'})[0].successful
        assert not system.arm.set_parameters([Parameter('publish_rate', value=-1.0)])[0].successful
        assert system.spin_until(lambda: len(system.planner_status) > n_planner
                                 and len(system.arm_status) > n_arm, 5.0)
        for status, name, words in ((system.planner_status[n_planner], 'method', 'quintic'),
                                    (system.arm_status[n_arm], 'publish_rate', '-1.0')):
            assert status.level == DiagnosticStatus.ERROR
            assert words in status.message and 'rejected' in status.message
            assert status_values(status)['parameters'] == name
        # Both keep serving: a request after the rejection is planned and played.
        status, trajectory = system.request(waypoint_message(
            pe.JOINT_NAMES, [[0.0, 0.0, 0.0], [0.3, 0.2, 0.1]]))
        assert_planned(status)
        assert trajectory is not None


def test_numbers_as_users_type_them_for_doubles_and_double_arrays():
    # Issue 18 review: -p waypoint_tolerance:=0 (an INTEGER for a double) killed
    # the node, and -p max_velocity:=[2,2,2] arrives as an INTEGER_ARRAY.
    with LocalRos() as ros:
        node = _planner(ros, ['-p', 'waypoint_tolerance:=0', '-p', 'max_velocity:=[2,2,3]',
                              '-p', 'min_position:=[-3,-3,-3]'])
        config = node.parameters.config
        assert config.waypoint_tolerance == 0.0 and config.max_velocity == (2.0, 2.0, 3.0)
        assert config.min_position == (-3.0, -3.0, -3.0)
        assert isinstance(node.get_parameter('waypoint_tolerance').value, float)
        assert node.get_parameter('max_velocity').type_ == Parameter.Type.DOUBLE_ARRAY
        # ros2 param set sends arrays as array.array (through the parameter service).
        message = ParameterMsg(name='max_position', value=ParameterValue(
            type=ParameterType.PARAMETER_INTEGER_ARRAY, integer_array_value=[3, 3, 3]))
        result = node.set_parameters([Parameter.from_parameter_msg(message)])[0]
        assert result.successful, result.reason
        assert node.parameters.config.max_position == (3.0, 3.0, 3.0)
        # Anything else is rejected with the reason; the node keeps its config.
        for name, value in (('waypoint_tolerance', 'a'), ('max_velocity', ['a', 'b', 'c']),
                            ('sample_period', True)):
            result = node.set_parameters([Parameter(name, value=value)])[0]
            assert not result.successful and name in result.reason, (name, result.reason)
        assert node.parameters.config.max_position == (3.0, 3.0, 3.0)


def test_descriptors_show_the_table_and_our_reason_rejects():
    # The range and choices are text (additional_constraints), not rclpy ranges:
    # an out-of-range value reaches our validation and its reason (issue 37).
    with LocalRos() as ros:
        node = _planner(ros, [])
        lead = node.describe_parameter('replan_lead_time')
        assert lead.additional_constraints == 'in [0.05, 10] s'
        assert list(lead.floating_point_range) == [] and lead.dynamic_typing
        assert 'planning must finish within it' in lead.description
        method = node.describe_parameter('method')
        assert method.additional_constraints == "one of ['445', '434', '555']"
        knots = node.describe_parameter('inner_knots')
        assert knots.additional_constraints == 'in [0, 8], or -1 (auto)'
        assert list(knots.integer_range) == [] and knots.type == ParameterType.PARAMETER_INTEGER
        assert node.describe_parameter('model_file').additional_constraints == ''
        result = node.set_parameters([Parameter('replan_lead_time', value=11.0)])[0]
        assert not result.successful
        assert result.reason == 'rejected: replan_lead_time = 11.0: must be in [0.05, 10] s'
        assert node.parameters.config.replan_lead_time == 0.2
        arm = ros.add(ArmSimNode(context=ros.context))
        rate = arm.describe_parameter('publish_rate')
        assert rate.additional_constraints == 'in [0.001, 1000] Hz'
        result = arm.set_parameters([Parameter('publish_rate', value=5000.0)])[0]
        assert result.reason == 'rejected: publish_rate = 5000.0: must be in [0.001, 1000] Hz'


def test_an_unexpected_error_applying_parameters_is_a_refusal_not_a_crash():
    """An OverflowError or a RecursionError from a file read for a parameter once left it."""
    with LocalRos() as ros:
        node = ros.add(ArmSimNode(context=ros.context))
        apply = node.parameters._on_change

        def broken(config):
            if config.publish_rate == 7.0:
                raise RecursionError('maximum recursion depth exceeded')
            return apply(config)
        node.parameters._on_change = broken
        result = node.set_parameters([Parameter('publish_rate', value=7.0)])[0]
        assert not result.successful
        assert 'RecursionError: maximum recursion depth exceeded' in result.reason
        assert node.get_parameter('publish_rate').value != 7.0
        assert node.set_parameters([Parameter('publish_rate', value=25.0)])[0].successful
        assert node.effective.publish_rate == 25.0


@pytest.mark.parametrize('node_cls, name', [(PlannerNode, 'min_position'),
                                            (PlannerNode, 'payload_inertia'),
                                            (ArmSimNode, 'payload_inertia')])
def test_an_empty_array_in_a_params_file_or_on_the_command_line_is_the_empty_array(
        tmp_path, node_cls, name):
    """An empty array comes as "not set" from rclpy: the documented default stopped the node."""
    node_name = 'planner_node' if node_cls is PlannerNode else 'arm_sim_node'
    path = os.path.join(tmp_path, 'params.yaml')
    with open(path, 'w', encoding='utf-8') as handle:
        handle.write(f'{node_name}:\n  ros__parameters:\n    {name}: []\n')
    for cli in (['--params-file', path], ['-p', f'{name}:=[]']):
        with LocalRos() as ros:
            node = ros.add(node_cls(context=ros.context, cli_args=['--ros-args'] + cli))
            assert getattr(node.parameters.config, name) == ()
            assert list(node.get_parameter(name).value) == []


def test_deleting_an_array_parameter_sets_it_empty():
    """`ros2 param delete` (a "not set" value) was refused with "got None"."""
    with LocalRos() as ros:
        node = _planner(ros, ['-p', 'min_position:=[-1.0, -1.0, -1.0]',
                              '-p', 'max_velocity:=[1.0, 1.0, 1.0]'])
        result = node.set_parameters([Parameter('min_position')])[0]   # not set: a delete
        assert result.successful, result.reason
        assert node.parameters.config.min_position == ()
        # Empty is "not set" for the limits: the planar arm's own again.
        result = node.set_parameters([Parameter('max_velocity')])[0]
        assert result.successful, result.reason
        assert node.parameters.config.max_velocity == (pe.MAX_VELOCITY[0],) * 3


def test_values_the_mode_ignores_are_warned_of_at_start_and_when_set(capfd):
    with LocalRos() as ros:
        node = ros.add(ArmSimNode(context=ros.context, cli_args=[
            '--ros-args', '-p', 'kp:=[1.0, 2.0, 3.0]', '-p', 'publish_rate:=20.0']))
        err = capfd.readouterr().err
        assert 'kp = (1.0, 2.0, 3.0) has no effect: simulation is kinematic' in err, err
        assert 'publish_rate' not in err  # used in every mode
        assert node.set_parameters([Parameter('gravity', value=False)])[0].successful
        err = capfd.readouterr().err
        assert 'gravity = False has no effect' in err and 'kp =' not in err, err
        # Dynamic: both are used; nothing more is said.
        assert node.set_parameters([Parameter('simulation', value='dynamic')])[0].successful
        assert 'has no effect' not in capfd.readouterr().err
        planner = _planner(ros, ['-p', 'link_lengths:=[1.0, 0.8]'])
        assert planner.parameters.config.kinematics == ''
        assert ("link_lengths = (1.0, 0.8) has no effect: they are the planar_3dof arm's"
                in capfd.readouterr().err)


def test_a_value_of_another_type_at_start_up_exits_2_with_the_reason(capsys):
    """The node exits 2 with the reason; rclpy refuses such a value itself (helper-78)."""
    with pytest.raises(SystemExit) as exited:
        run_node(PlannerNode, ['planner_node', '--ros-args', '-p',
                               "max_trajectory_points:='5'"])
    assert exited.value.code == 2
    out = capsys.readouterr().out
    assert 'PlannerNode: invalid parameters' in out and 'max_trajectory_points' in out, out

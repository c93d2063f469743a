"""
The parameter tables: declared once, in the config fields, and doc/nodes.md generated from them.

``doc/nodes.md`` must hold exactly the tables ``scripts/parameter_docs.py``
writes (edit a row there, or a field, and the first test fails until the
script is run); every field is a row with a description; and a value
outside a row's bounds or choices is refused by ``from_values`` with those
bounds in the reason (the expected messages are written out here).
"""

from dataclasses import dataclass, fields
import math
import os
from typing import Tuple

import pytest
from splines445_ros.service.arm_sim_config import ArmSimConfig
from splines445_ros.service.parameter_table import (markdown_table, not_set_values, parameter,
                                                    rewrite_tables, row_of)
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.service.validated_config import ValidatedConfig

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PAGE = os.path.join(ROOT, 'doc', 'nodes.md')
TABLES = {'planner_node': PlannerConfig, 'arm_sim_node': ArmSimConfig}
CONFIGS = [PlannerConfig, ArmSimConfig]


def read_page():
    with open(PAGE, encoding='utf-8') as handle:
        return handle.read()


def test_doc_nodes_holds_exactly_the_generated_tables():
    text = read_page()
    for name in TABLES:
        assert f'<!-- parameters: {name} -->' in text
    assert rewrite_tables(text, TABLES) == text, 'run scripts/parameter_docs.py'


def test_an_edited_row_is_noticed_and_rewritten():
    text = read_page()
    row = '| `publish_rate` | double | `50.0` |'
    assert text.count(row) == 1
    edited = text.replace(row, '| `publish_rate` | double | `60.0` |')
    assert rewrite_tables(edited, TABLES) == text
    # A table missing altogether is an error, not silence.
    without = text.replace('<!-- parameters: arm_sim_node -->', '')
    with pytest.raises(ValueError, match='arm_sim_node'):
        rewrite_tables(without, TABLES)


@dataclass(frozen=True)
class Tiny(ValidatedConfig):
    """A config of three rows, to see the table's format."""

    rate: float = parameter(50.0, 'How often [Hz].', low=1.0, high=100.0, unit='Hz')
    mode: str = parameter('a', 'The | mode.', choices=('a', 'b'))
    names: Tuple[str, ...] = parameter(('x',), 'Names.', declared=('',))
    count: int = parameter(-1, 'How many.', low=0, high=8, special=(-1, 'auto'))

    def validate(self):
        """Only the table."""
        self.check_table()


def test_the_markdown_table_of_a_small_config():
    assert markdown_table(Tiny).split('\n') == [
        '| parameter | type | default | valid | meaning |',
        '|---|---|---|---|---|',
        '| `rate` | double | `50.0` | in [1, 100] Hz | How often [Hz]. |',
        "| `mode` | string | `a` | one of ['a', 'b'] | The \\| mode. |",
        "| `names` | string[] | not set (`['']`) |  | Names. |",
        '| `count` | int | `-1` | in [0, 8], or -1 (auto) | How many. |']
    page = 'Intro\n<!-- parameters: tiny -->\nold\n<!-- end parameters -->\nEnd\n'
    assert rewrite_tables(page, {'tiny': Tiny}) == (
        'Intro\n<!-- parameters: tiny -->\n\n' + markdown_table(Tiny)
        + '\n\n<!-- end parameters -->\nEnd\n')
    assert not_set_values(Tiny) == {'names': ('',)}
    Tiny.from_values({'rate': 1.0, 'count': 8})
    Tiny.from_values({'count': -1})
    for values, message in (({'rate': 0.5}, 'rate = 0.5: must be in [1, 100] Hz'),
                            ({'count': -2}, 'count = -2: must be in [0, 8], or -1 (auto)'),
                            ({'mode': 'c'}, "mode must be one of ['a', 'b'], got 'c'")):
        with pytest.raises(ValueError) as refused:
            Tiny.from_values(values)
        assert str(refused.value) == message


@pytest.mark.parametrize('config', CONFIGS)
def test_every_field_is_a_row_with_a_description(config):
    for field in fields(config):
        row = row_of(field)
        assert row.description.strip(), field.name
        if row.declared is not None:  # a "not set" value of the field's type
            assert type(row.declared) is type(field.default), field.name


PLANNER_REFUSED = [
    ({'replan_lead_time': 10.5}, 'replan_lead_time = 10.5: must be in [0.05, 10] s'),
    ({'replan_lead_time': 0.0}, 'replan_lead_time = 0.0: must be in [0.05, 10] s'),
    ({'goal_time_tolerance': -1.0}, 'goal_time_tolerance = -1.0: must be in [0, 3600] s'),
    ({'vibration_frequency': 1e4},
     'vibration_frequency = 10000.0: must be in [0.1, 1000] Hz, or 0 (not used)'),
    ({'vibration_frequency': 1e-6},
     'vibration_frequency = 1e-06: must be in [0.1, 1000] Hz, or 0 (not used)'),
    ({'sample_period': 5e-05}, 'sample_period = 5e-05: must be in [0.0001, 10] s'),
    ({'sample_period': 3e9}, 'sample_period = 3000000000.0: must be in [0.0001, 10] s'),
    ({'max_trajectory_points': 1}, 'max_trajectory_points = 1: must be at least 2'),
    ({'inner_knots': 9}, 'inner_knots = 9: must be in [0, 8], or -1 (auto)'),
    ({'max_inserted_waypoints': 100001},
     'max_inserted_waypoints = 100001: must be in [0, 100000]'),
    ({'torque_headroom': 0.5}, 'torque_headroom = 0.5: must be in [0, 0.5) (the share of every '
                               "torque limit left to the controller's corrections)"),
    ({'max_tool_speed': -0.1}, 'max_tool_speed = -0.1: must be >= 0 and finite (m/s; 0 = no '
                               'limit)'),
    ({'max_path_deviation': math.inf},
     'max_path_deviation = inf: must be >= 0 and finite (0 = not checked)'),
    ({'goal_velocity_tolerance': 0.0},
     'goal_velocity_tolerance = 0.0: must be positive and finite'),
    ({'method': '544'}, "method must be one of ['445', '434', '555'], got '544'"),
    ({'kinematics': 'urdf'},
     "kinematics must be one of ['', 'planar_3dof', 'model'] (\"\" = joint space only), "
     "got 'urdf'"),
]
ARM_REFUSED = [
    ({'publish_rate': 2000}, 'publish_rate = 2000.0: must be in [0.001, 1000] Hz'),
    ({'physics_rate': 500.0}, 'physics_rate = 500.0: must be in [1000, 20000] Hz'),
    ({'control_damping_ratio': 0.01}, 'control_damping_ratio = 0.01: must be in [0.05, 5]'),
    ({'spring_damping_ratio': 2.5}, 'spring_damping_ratio = 2.5: must be in [0, 2]'),
    ({'simulation': 'physics'},
     "simulation must be one of ['kinematic', 'dynamic'], got 'physics'"),
]


@pytest.mark.parametrize('config, values, message',
                         [(PlannerConfig, v, m) for v, m in PLANNER_REFUSED]
                         + [(ArmSimConfig, v, m) for v, m in ARM_REFUSED])
def test_a_value_outside_the_table_is_refused_with_its_bounds(config, values, message):
    with pytest.raises(ValueError) as refused:
        config.from_values(values)
    assert str(refused.value) == message


def test_values_on_the_bounds_are_accepted():
    for values in ({'replan_lead_time': 10.0}, {'replan_lead_time': 0.05},
                   {'sample_period': 1e-4}, {'sample_period': 10.0},
                   {'inner_knots': -1}, {'inner_knots': 8},
                   {'max_inserted_waypoints': 0}, {'goal_time_tolerance': 3600.0}):
        config = PlannerConfig.from_values(values)
        assert all(getattr(config, k) == v for k, v in values.items())
    for values in ({'publish_rate': 0.001}, {'physics_rate': 20000.0},
                   {'control_damping_ratio': 5.0, 'model_file': 'arm.xml'},  # (model_file's)
                   {'spring_damping_ratio': 0.0}):
        ArmSimConfig.from_values(values)


def test_spring_damping_ratio_is_only_checked_for_the_built_in_arm():
    # With a model file the built-in arm's springs are not used (and never were checked).
    config = ArmSimConfig.from_values({'model_file': 'arm.xml', 'spring_damping_ratio': 2.5})
    assert config.spring_damping_ratio == 2.5


def _outside(row):
    """Return a value just outside the row's bounds (not its special value)."""
    if row.high is not None:
        return row.high + (1 if isinstance(row.high, int) else abs(row.high) + 1.0)
    value = row.low - (1 if isinstance(row.low, int) else 1.0)
    if row.special is not None and value == row.special[0]:
        value -= 1
    return value


@pytest.mark.parametrize('config', CONFIGS)
def test_every_row_with_bounds_or_choices_is_enforced(config):
    checked = 0
    for field in fields(config):
        row = row_of(field)
        if row.choices is not None:
            value, said = 'no such value', f'{field.name} must be one of'
        elif row.low is not None or row.high is not None:
            value, said = _outside(row), f'{field.name} = '
        else:
            continue
        with pytest.raises(ValueError) as refused:
            config.from_values({field.name: value})
        assert str(refused.value).startswith(said), str(refused.value)
        if row.low is not None and row.choices is None:
            assert f'{row.low:g}' in str(refused.value)
        checked += 1
    assert checked >= (15 if config is PlannerConfig else 6)


@pytest.mark.parametrize('name, value', [('model_file', '/dev/zero'),
                                         ('joint_limits_file', '/dev/zero'),
                                         ('tool_frame', 'tool0'), ('base_frame', 'base_link')])
def test_the_robots_files_and_frames_are_refused_without_kinematics_model(name, value):
    """They would be ignored (helper-36: a joint_limits_file of /dev/zero was accepted)."""
    for kinematics in ('', 'planar_3dof'):
        with pytest.raises(ValueError, match=f'{name} is set but kinematics is'):
            PlannerConfig(kinematics=kinematics, **{name: value}).validate()

"""
The package layout: one folder per concept, and who may import whom.

The rules (also in each folder's ``__init__`` docstring)::

    planning   numpy/scipy only: no ROS, nothing else from the package
    robot      may import planning; no ROS
    cartesian  may import robot and planning; no ROS
    sim        may import robot and planning; no ROS
    service    may import sim, cartesian, robot and planning; no ROS
    nodes      may import service and everything below it (and ROS); never tools
    tools      may import everything but the deprecated arm
    arm        deprecated re-exports of robot, sim and cartesian; no ROS

Inside ``planning`` each room imports only the rooms before it (and the
three top modules as :data:`PLANNING_MAY_IMPORT` says)::

    spline, durations, constraints, speed_profile, path_following; then planner

They are checked by reading every module's imports with :mod:`ast` (imports
inside functions included), so nothing is executed and a lazy import cannot
hide.  ``test_checker_flags_bad_imports`` runs the same checker on a small
package written in the test, with one deliberate violation of each kind, so
the rule test is known to be able to fail.
"""

import ast
import configparser
import importlib
import os
import re
import sys

from file_tree import write_file
import pytest

PACKAGE = 'splines445_ros'
ROOT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), PACKAGE)

# Layer -> the package layers it may import.
MAY_IMPORT = {
    'planning': {'planning'},
    'robot': {'robot', 'planning'},
    'cartesian': {'cartesian', 'robot', 'planning'},
    'sim': {'sim', 'robot', 'planning'},
    'service': {'service', 'sim', 'cartesian', 'robot', 'planning'},
    'nodes': {'nodes', 'service', 'sim', 'cartesian', 'robot', 'planning'},
    'tools': {'tools', 'nodes', 'service', 'sim', 'cartesian', 'robot', 'planning'},
    'arm': {'arm', 'robot', 'sim', 'cartesian', 'planning'},
}
# The rooms of planning (and its three top modules) -> the ones each may import.
# ``planning/__init__.py`` (the public API) may import them all.
PLANNING_MAY_IMPORT = {
    'validation': set(),
    'spline': {'validation'},
    'durations': {'spline', 'validation'},
    'constraints': {'spline', 'validation'},
    'speed_profile': {'constraints', 'spline', 'validation'},
    'plan_options': {'constraints', 'spline', 'validation'},
    'path_following': {'speed_profile', 'constraints', 'durations', 'spline', 'plan_options',
                       'validation'},
}
PLANNING_MAY_IMPORT['planner'] = set(PLANNING_MAY_IMPORT)
PLANNING_ROOMS = sorted(name for name in PLANNING_MAY_IMPORT
                        if name not in ('validation', 'plan_options', 'planner'))
ROS_FREE = {'planning', 'robot', 'cartesian', 'sim', 'service', 'arm'}
ROS_MODULES = {'rclpy', 'rcl_interfaces', 'builtin_interfaces', 'launch', 'launch_ros',
               'ament_index_python', 'rosidl_runtime_py'}


def is_ros_module(name):
    """Return True for rclpy and ROS 2 message / runtime packages."""
    top = name.split('.')[0]
    return (top in ROS_MODULES or top.endswith(('_msgs', '_srvs')) or top.startswith('rosidl')
            or top.startswith('tf2'))


def modules(root):
    """Yield (dotted module name, path) of every .py file below the package ``root``."""
    base = os.path.dirname(root)
    for folder, _, files in os.walk(root):
        for name in sorted(files):
            if name.endswith('.py'):
                path = os.path.join(folder, name)
                rel = os.path.relpath(path, base)[:-3].split(os.sep)
                if rel[-1] == '__init__':
                    rel = rel[:-1]
                yield '.'.join(rel), path


def imported_names(module, path):
    """Absolute names of everything ``module`` (at ``path``) imports, with line numbers."""
    with open(path, encoding='utf-8') as handle:
        tree = ast.parse(handle.read(), path)
    is_package = os.path.basename(path) == '__init__.py'
    package = module.split('.') if is_package else module.split('.')[:-1]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                anchor = package[:len(package) - node.level + 1]
                base = '.'.join(anchor + ([node.module] if node.module else []))
            else:
                base = node.module
            # "from pkg import sub" may import a subpackage: name both.
            found.append((node.lineno, base))
            found += [(node.lineno, f'{base}.{alias.name}') for alias in node.names]
    return found


def layer_of(module):
    """Return the layer (first folder below the package) of a dotted module name."""
    parts = module.split('.')
    return parts[1] if len(parts) > 1 else ''


def room_of(module):
    """Return the room of ``planning`` (or its top module) a dotted name is in, or ''."""
    parts = module.split('.')
    return parts[2] if len(parts) > 2 and parts[1] == 'planning' else ''


def planning_violations(module, names, package, place):
    """
    Broken room rules of one module inside ``planning``, as readable strings.

    ``names`` are its (line, imported name) pairs (:func:`imported_names`),
    ``place`` its path as the errors give it.
    """
    room, found = room_of(module), []
    whole = f'{package}.planning'
    # "from .. import x" names the package too, as the base of its x: not on its own.
    bases = {line for line, name in names if name.startswith(whole + '.')}
    for line, name in names:
        where = f'{place}:{line}'
        if name.split('.')[0] != package:
            continue
        if name == whole and line not in bases:
            # The package itself is planner's API (plan(), PlanOptions): a room above all.
            found.append(f'{where}: planning.{room} imports the planning package itself')
            continue
        target = room_of(name)
        if target and target != room and target not in PLANNING_MAY_IMPORT.get(room, set()):
            found.append(f'{where}: planning.{room} imports {name}')
    return found


def violations(root):
    """Every broken rule below the package ``root``, as readable strings."""
    package = os.path.basename(root)
    found = []
    for module, path in modules(root):
        layer = layer_of(module)
        if module == package:
            continue
        if layer not in MAY_IMPORT:
            found.append(f'{module}: outside the layer folders {sorted(MAY_IMPORT)}')
            continue
        if (layer == 'planning' and module.count('.') > 1
                and room_of(module) not in PLANNING_MAY_IMPORT):
            found.append(f'{module}: outside the rooms of planning {sorted(PLANNING_MAY_IMPORT)}')
        names = imported_names(module, path)
        place = os.path.relpath(path, os.path.dirname(root))
        if layer == 'planning' and room_of(module):
            found += planning_violations(module, names, package, place)
        for line, name in names:
            where = f'{place}:{line}'
            if name.split('.')[0] == package:
                target = layer_of(name)
                if target in MAY_IMPORT and target not in MAY_IMPORT[layer]:
                    found.append(f'{where}: {layer} imports {name}')
            elif layer in ROS_FREE and is_ros_module(name):
                found.append(f'{where}: {layer} imports ROS module {name}')
    return sorted(set(found))


def import_cycles(root):
    """
    Return the groups of modules below ``root`` that import each other (directly or in a ring).

    Each group is a sorted list of dotted names; the groups are sorted.  An
    import of a name inside a module (``from .a import f``) counts as an
    import of that module.
    """
    paths = dict(modules(root))
    graph = {module: {name for _, name in imported_names(module, path)
                      if name in paths and name != module}
             for module, path in paths.items()}

    def reachable(start):
        seen, todo = set(), [start]
        while todo:
            for name in graph[todo.pop()] - seen:
                seen.add(name)
                todo.append(name)
        return seen

    reach = {module: reachable(module) for module in graph}
    groups = {tuple(sorted({module} | {other for other in reach[module]
                                       if module in reach[other]}))
              for module in graph if module in reach[module]}
    return sorted(list(group) for group in groups)


def test_no_modules_import_each_other():
    # Issue 22: arm/robot_model and arm/mujoco_model imported each other (one lazily).
    assert import_cycles(ROOT) == []


def test_cycle_checker_flags_mutual_and_ring_imports(tmp_path):
    root = str(tmp_path / 'pkg')
    write_file(root, '__init__.py', '')
    write_file(root, 'arm/__init__.py', '"""Layer."""\n')
    write_file(root, 'arm/a.py', 'from .b import f\n')
    write_file(root, 'arm/b.py', 'def f():\n    from . import a\n')
    write_file(root, 'arm/c.py', 'import pkg.arm.d\n')
    write_file(root, 'arm/d.py', 'from pkg.arm import e\n')
    write_file(root, 'arm/e.py', 'from .c import g\nfrom . import a\n')
    write_file(root, 'arm/leaf.py', 'from . import a\n')
    assert import_cycles(root) == [['pkg.arm.a', 'pkg.arm.b'],
                                   ['pkg.arm.c', 'pkg.arm.d', 'pkg.arm.e']]


def test_layers_import_only_what_they_may():
    assert os.path.isdir(os.path.join(ROOT, 'planning'))
    assert violations(ROOT) == []


def test_every_folder_states_its_rules():
    for layer in list(MAY_IMPORT) + [f'planning/{room}' for room in PLANNING_ROOMS]:
        with open(os.path.join(ROOT, layer, '__init__.py'), encoding='utf-8') as handle:
            doc = ast.get_docstring(ast.parse(handle.read()))
        assert doc and 'May import' in doc, f'{layer}/__init__.py must say what it may import'
        if layer.startswith('planning/'):
            # ... and names every room or top module of planning it may import.
            rule = ' '.join(doc[doc.index('May import'):].split())
            for allowed in PLANNING_MAY_IMPORT[layer.split('/')[1]]:
                named = f'``{allowed}``' in rule or f'``planning.{allowed}``' in rule
                assert named, f'{layer}/__init__.py: may it import {allowed}? Say so.'


def test_checker_flags_bad_imports(tmp_path):
    root = str(tmp_path / 'pkg')
    for layer in MAY_IMPORT:
        write_file(root, f'{layer}/__init__.py', '"""Layer."""\n')
    # Each file's path and text, with one broken rule of each kind.
    files = {
        '__init__.py': '',
        'planning/core.py': 'import numpy\nfrom rclpy.node import Node\n',
        'planning/sneaky.py': 'def f():\n    from ..robot import kinematics\n',
        'robot/sim.py': 'from .. import planning\nfrom geometry_msgs.msg import Pose\n',
        'robot/up.py': 'import pkg.nodes.node\nimport tf2_ros\n',
        'nodes/node.py': 'import rclpy\nfrom ..robot import sim\nfrom pkg.tools import demo\n',
        'tools/demo.py': 'from ..nodes import node\nfrom ..planning import core\n',
        'nodes/old.py': 'from ..arm import kinematics\n',
        'service/up.py': 'from ..nodes import node\n',
        'stray.py': 'import os\n',
        'planning/spline/__init__.py': '"""Room."""\n',
        'planning/spline/up.py': ('from ..validation import checked\n'
                                  'from ..durations import timing\n'),
        'planning/durations/__init__.py': '"""Room."""\n',
        'planning/durations/timing.py': 'from ..spline import up\n',
        'planning/durations/lazy.py': 'def f():\n    from ..planner import plan\n',
        'planning/attic/old.py': 'import os\n',
        'planning/validation.py': 'from .spline import up\n',
        'planning/durations/whole.py': 'import pkg.planning\nfrom pkg import planning\n',
        'planning/durations/fine.py': 'import foo.planning.bar\nfrom .. import validation\n',
    }
    for path, text in files.items():
        write_file(root, path, text)
    found = violations(root)
    expected = [
        'pkg.stray: outside the layer folders',
        'pkg/robot/sim.py:2: robot imports ROS module geometry_msgs.msg',
        'pkg/robot/up.py:1: robot imports pkg.nodes.node',
        'pkg/robot/up.py:2: robot imports ROS module tf2_ros',
        'pkg/nodes/node.py:3: nodes imports pkg.tools',
        'pkg/planning/core.py:2: planning imports ROS module rclpy.node',
        'pkg/planning/sneaky.py:2: planning imports pkg.robot',
        'pkg/nodes/old.py:1: nodes imports pkg.arm',
        'pkg/service/up.py:1: service imports pkg.nodes',
        'pkg/planning/spline/up.py:2: planning.spline imports pkg.planning.durations',
        'pkg/planning/durations/lazy.py:2: planning.durations imports pkg.planning.planner',
        'pkg.planning.attic.old: outside the rooms of planning',
        'pkg/planning/validation.py:1: planning.validation imports pkg.planning.spline',
        'pkg/planning/durations/whole.py:1: planning.durations imports the planning package',
        'pkg/planning/durations/whole.py:2: planning.durations imports the planning package',
    ]
    for text in expected:
        assert any(v.startswith(text) for v in found), (text, found)
    # Allowed imports (tools -> nodes/planning, nodes -> robot, robot -> planning) are not flagged.
    assert not any('tools/demo.py' in v or 'robot/sim.py:1' in v or 'node.py:2' in v
                   or 'spline/up.py:1' in v or 'durations/timing.py' in v or 'fine.py' in v
                   for v in found), found


def _console_scripts():
    setup_py = os.path.join(os.path.dirname(ROOT), 'setup.py')
    with open(setup_py, encoding='utf-8') as handle:
        text = handle.read()
    return dict(re.findall(r"'(\w+) = ([\w.]+:\w+)'", text))


def test_executables_keep_their_names_and_resolve():
    scripts = _console_scripts()
    # The names `ros2 run splines445_ros <name>` users type.
    assert {'planner_node', 'arm_sim_node', 'demo', 'plot_trajectory'} <= set(scripts)
    for target in scripts.values():
        module, function = target.split(':')
        assert callable(getattr(importlib.import_module(module), function)), target
    config = configparser.ConfigParser()
    config.read(os.path.join(os.path.dirname(ROOT), 'setup.cfg'))
    # ament_python: executables go to lib/<package>, where `ros2 run` looks.
    assert config['install']['install_scripts'] == f'$base/lib/{PACKAGE}'


@pytest.mark.parametrize('layer', sorted(MAY_IMPORT))
def test_layer_is_a_package(layer):
    assert importlib.import_module(f'{PACKAGE}.{layer}').__doc__


@pytest.mark.parametrize('old, new, name', [
    ('arm.dynamics', 'robot.dynamics', 'ArmDynamics'),
    ('arm.inverse_kinematics', 'robot.inverse_kinematics', 'ModelKinematics'),
    ('arm.kinematics', 'robot.kinematics', 'PlanarArm'),
    ('arm.robot_model', 'robot.robot_model', 'load_robot_model'),
    ('arm.tool_paths', 'cartesian.tool_paths', 'plan_tool_path'),
])
def test_old_import_paths_still_work_with_a_deprecation_warning(old, new, name):
    sys.modules.pop(f'{PACKAGE}.{old}', None)
    with pytest.warns(DeprecationWarning, match=new.replace('.', r'\.')):
        module = importlib.import_module(f'{PACKAGE}.{old}')
    assert getattr(module, name) is getattr(importlib.import_module(f'{PACKAGE}.{new}'), name)

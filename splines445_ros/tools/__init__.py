"""
User tools on top of the nodes: the demo, reports, figures, plot_trajectory, the harness.

Lives here: the ``demo`` and ``plot_trajectory`` executables, the demo's
tables and figures (matplotlib, Agg backend), the straight-tool-path part of
the demo (``tool_path_demo``) and the in-process harness that
spins both nodes and a client in one executor (used by the demo and the tests).

May import: everything in the package but the deprecated ``arm``
(:mod:`splines445_ros.planning`, ``robot``, ``cartesian``, ``sim``,
``service``, ``nodes``); nothing imports
from here but the executables and the tests (``test/test_layout.py`` checks this).
"""

"""Fixtures of the node tests that several modules use."""

import pytest
from splines445_ros.service import model_planning
from test_robot_loading_node import HeldCompiles


@pytest.fixture
def compiles(monkeypatch):
    """Count the planner's model compiles, and hold them while ``hold`` is set."""
    held = HeldCompiles(model_planning.load_robot_model)
    monkeypatch.setattr(model_planning, 'load_robot_model', held)
    yield held
    held.release.set()

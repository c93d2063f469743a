"""Validated configuration of the simulated planar arm (pure Python, no rclpy)."""

from dataclasses import dataclass
import math
from typing import Tuple

from .planner_config import DEFAULT_JOINTS
from .validated_config import ValidatedConfig

MIN_PUBLISH_RATE = 0.001
MAX_PUBLISH_RATE = 1000.0


@dataclass(frozen=True)
class ArmSimConfig(ValidatedConfig):
    """Parameters of ``arm_sim_node``."""

    joint_names: Tuple[str, ...] = DEFAULT_JOINTS
    link_lengths: Tuple[float, ...] = (1.1, 0.9)
    initial_positions: Tuple[float, ...] = (0.0, 0.0, 0.0)
    publish_rate: float = 50.0
    frame_id: str = 'base_link'

    def validate(self):
        """Raise ValueError with the reason when any value is unusable."""
        names = self.joint_names
        if len(names) != 3 or any(not isinstance(n, str) or not n for n in names):
            raise ValueError(f'joint_names must be 3 non-empty names (the planar arm has 3 '
                             f'joints), got {list(names)}')
        if len(set(names)) != 3:
            raise ValueError(f'joint_names has duplicates: {list(names)}')
        if len(self.link_lengths) != 2 or not all(
                math.isfinite(v) and v > 0.0 for v in self.link_lengths):
            raise ValueError(f'link_lengths must be 2 positive lengths, got '
                             f'{list(self.link_lengths)}')
        if len(self.initial_positions) != 3 or not all(
                math.isfinite(v) for v in self.initial_positions):
            raise ValueError(f'initial_positions must be 3 finite angles, got '
                             f'{list(self.initial_positions)}')
        if not (math.isfinite(self.publish_rate)
                and MIN_PUBLISH_RATE <= self.publish_rate <= MAX_PUBLISH_RATE):
            raise ValueError(f'publish_rate = {self.publish_rate}: must be in '
                             f'[{MIN_PUBLISH_RATE}, {MAX_PUBLISH_RATE}] Hz')

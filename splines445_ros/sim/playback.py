"""
Playback of a sampled joint trajectory (pure Python, no rclpy).

Between two samples the state is interpolated like ros2_control's
joint_trajectory_controller does: a quintic Hermite polynomial when every
sample has positions, velocities and accelerations, a cubic one with
positions and velocities, linear with positions only.
"""

import numpy as np

# The largest |position|, |velocity| or |acceleration| a trajectory may carry
# (rad, m, per s, per s^2): far beyond any arm, and far below where the
# interpolation and the arm's kinematics overflow (1e308 did, helper-36).
MAX_MAGNITUDE = 1e6


class SampledTrajectory:
    """Samples (K,) times and (K, n) positions / velocities / accelerations."""

    def __init__(self, times, positions, velocities=None, accelerations=None):
        """Check shapes, finiteness and strictly increasing times (ValueError)."""
        self.times = np.asarray(times, dtype=float)
        self.positions = np.asarray(positions, dtype=float)
        K = self.times.size
        if K == 0:
            raise ValueError('trajectory has no points')
        if self.positions.ndim != 2 or self.positions.shape[0] != K:
            raise ValueError(f'positions must have shape ({K}, n), got {self.positions.shape}')
        n = self.positions.shape[1]
        self.velocities = None if velocities is None else np.asarray(velocities, dtype=float)
        self.accelerations = (None if accelerations is None
                              else np.asarray(accelerations, dtype=float))
        for name in ('velocities', 'accelerations'):
            value = getattr(self, name)
            if value is not None and value.shape != (K, n):
                raise ValueError(f'{name} must have shape ({K}, {n}), got {value.shape}')
        for name in ('times', 'positions', 'velocities', 'accelerations'):
            value = getattr(self, name)
            if value is not None and not np.all(np.isfinite(value)):
                bad = np.argwhere(~np.isfinite(value))[0]
                raise ValueError(f'{name} has a non-finite value at {tuple(int(i) for i in bad)}')
            if value is not None and name != 'times' and np.any(np.abs(value) > MAX_MAGNITUDE):
                bad = np.argwhere(np.abs(value) > MAX_MAGNITUDE)[0]
                raise ValueError(f'{name} has a value of magnitude above {MAX_MAGNITUDE:g} at '
                                 f'{tuple(int(i) for i in bad)}: {value[tuple(bad)]:g}')
        if np.any(self.times < 0.0):
            raise ValueError('time_from_start must not be negative')
        steps = np.diff(self.times)
        if np.any(steps <= 0.0):
            k = int(np.argwhere(steps <= 0.0)[0][0])
            raise ValueError(f'time_from_start must increase strictly: point {k + 1} '
                             f'({self.times[k + 1]} s) is not after point {k} '
                             f'({self.times[k]} s)')

    @property
    def duration(self):
        """Time of the last sample."""
        return float(self.times[-1])

    def with_start_state(self, position, velocity, acceleration, at=0.0):
        """
        Prepend the current state at t = ``at`` when the first sample is later than that.

        ``at`` [s] is when, in this trajectory's time, it takes over: 0 at its
        stamp, later when it arrives (or the switch is handled) after that.
        The arm then goes from where it is, when it is there, to the first
        sample, as joint_trajectory_controller interpolates from the state it
        had when it first sampled the new trajectory; one whose first sample
        has passed already starts part-way along, as there.
        """
        at = max(float(at), 0.0)
        if self.times[0] <= at:
            return self
        # The arm's own state, bounded as a message's values are: between two fuzzed points
        # milliseconds apart it reached 1.3e6 rad/s^2, and the prepended point was refused
        # inside the arm's timer (an exception out of the executor).
        velocity, acceleration = (np.clip(np.asarray(v, dtype=float), -MAX_MAGNITUDE,
                                          MAX_MAGNITUDE) for v in (velocity, acceleration))
        vel = None if self.velocities is None else np.vstack([velocity, self.velocities])
        acc = None if self.accelerations is None else np.vstack(
            [acceleration, self.accelerations])
        return SampledTrajectory(np.concatenate([[at], self.times]),
                                 np.vstack([position, self.positions]), vel, acc)

    def state_at(self, t):
        """Position, velocity and acceleration (n,) each at time ``t`` (clamped)."""
        n = self.positions.shape[1]
        zero = np.zeros(n)
        if t >= self.times[-1] or self.times.size == 1:
            vel = zero if self.velocities is None else self.velocities[-1]
            acc = zero if self.accelerations is None else self.accelerations[-1]
            if t >= self.times[-1]:
                return self.positions[-1].copy(), vel.copy(), acc.copy()
        t = max(t, float(self.times[0]))
        k = int(np.clip(np.searchsorted(self.times, t, side='right') - 1, 0,
                        self.times.size - 2))
        h = self.times[k + 1] - self.times[k]
        s = (t - self.times[k]) / h
        p0, p1 = self.positions[k], self.positions[k + 1]
        if self.velocities is None:
            v = (p1 - p0) / h
            return p0 + s * (p1 - p0), v, zero
        v0, v1 = self.velocities[k] * h, self.velocities[k + 1] * h
        if self.accelerations is None:
            a0 = a1 = zero
            quintic = False
        else:
            a0, a1 = self.accelerations[k] * h * h, self.accelerations[k + 1] * h * h
            quintic = True
        c = _hermite(p0, v0, a0, p1, v1, a1, quintic)
        pos = ((((c[5] * s + c[4]) * s + c[3]) * s + c[2]) * s + c[1]) * s + c[0]
        vel = (((5 * c[5] * s + 4 * c[4]) * s + 3 * c[3]) * s + 2 * c[2]) * s + c[1]
        acc = ((20 * c[5] * s + 12 * c[4]) * s + 6 * c[3]) * s + 2 * c[2]
        return pos, vel / h, acc / (h * h)

    def states_at(self, times):
        """
        Positions, velocities and accelerations (K, n) each at ``times`` (K,), vectorised.

        The same interpolation as :meth:`state_at`; times are clamped to the
        first sample, and from the last sample on the state is the last point
        with zero velocity and acceleration (the arm holds it).
        """
        t = np.asarray(times, dtype=float)
        K, n = t.size, self.positions.shape[1]
        pos = np.empty((K, n))
        vel = np.zeros((K, n))
        acc = np.zeros((K, n))
        done = t >= self.times[-1]
        pos[done] = self.positions[-1]
        live = ~done
        if not np.any(live):
            return pos, vel, acc
        tl = np.maximum(t[live], float(self.times[0]))
        k = np.clip(np.searchsorted(self.times, tl, side='right') - 1, 0, self.times.size - 2)
        h = (self.times[k + 1] - self.times[k])[:, None]
        s = (tl - self.times[k])[:, None] / h
        p0, p1 = self.positions[k], self.positions[k + 1]
        if self.velocities is None:
            pos[live] = p0 + s * (p1 - p0)
            vel[live] = (p1 - p0) / h
            return pos, vel, acc
        v0, v1 = self.velocities[k] * h, self.velocities[k + 1] * h
        zero = np.zeros_like(p0)
        if self.accelerations is None:
            a0 = a1 = zero
        else:
            a0, a1 = self.accelerations[k] * h * h, self.accelerations[k + 1] * h * h
        c = _hermite(p0, v0, a0, p1, v1, a1, self.accelerations is not None)
        pos[live] = ((((c[5] * s + c[4]) * s + c[3]) * s + c[2]) * s + c[1]) * s + c[0]
        vel[live] = ((((5 * c[5] * s + 4 * c[4]) * s + 3 * c[3]) * s + 2 * c[2]) * s
                     + c[1]) / h
        acc[live] = (((20 * c[5] * s + 12 * c[4]) * s + 6 * c[3]) * s + 2 * c[2]) / (h * h)
        return pos, vel, acc


def _hermite(p0, v0, a0, p1, v1, a1, quintic):
    """Ascending coefficients in s in [0, 1] matching the scaled end derivatives."""
    d = p1 - p0
    if not quintic:
        zero = np.zeros_like(d)
        return (p0, v0, 3 * d - 2 * v0 - v1, -2 * d + v0 + v1, zero, zero)
    return (p0, v0, 0.5 * a0,
            10 * d - 6 * v0 - 4 * v1 - 1.5 * a0 + 0.5 * a1,
            -15 * d + 8 * v0 + 7 * v1 + 1.5 * a0 - a1,
            6 * d - 3 * v0 - 3 * v1 - 0.5 * a0 + 0.5 * a1)

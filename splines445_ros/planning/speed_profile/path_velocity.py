"""
Time-optimal speed along a fixed joint path under first- and second-order constraints.

A path ``q(s)`` (here the 555 spline through the waypoints, in its own
time ``s``) is traversed at path speed ``sdot(t)``; with ``x = sdot**2`` and
``u = sddot`` the joint velocity and acceleration are::

    qdot = q'(s) sdot,        qddot = q'(s) u + q''(s) x

so the limits ``|qdot_j| <= v_j`` and ``|qddot_j| <= a_j`` are linear in
``(x, u)`` at every point of the path.  On a grid ``s_0 < ... < s_M`` with
``u`` constant between grid points, ``x_{i+1} = x_i + 2 u_i (s_{i+1} - s_i)``:
the classic reachability analysis (Pham & Pham's TOPP-RA, with one
constraint per joint the per-step problem is an interval, no LP) gives the
largest ``x`` from which the end is still reachable (backward pass) and the
fastest profile that stays within it (forward pass).

The limits come as constraint objects (:mod:`constraints`): joint
velocity and tool speed bound ``x``; joint acceleration and joint torque
are rows ``lo <= a u + b x <= hi``, each giving ``u`` an interval whose ends
are linear in ``x``.  A constraint that asks for it (``interpolated``, the
joint torque of :mod:`inner_knots`) holds at both ends of every step with
that step's ``u``, not only at its grid points (TOPP-RA's "interpolation"
discretisation).

Only the ideas are used here: the spline later built from this profile
(:mod:`inner_knots`) is what is checked exactly against the limits, jerk
included, so this profile only needs to be a good reference.

Limits may be multiplied along the path by a local factor ``scale`` (a time
scaling: velocity limit times ``scale``, acceleration times ``scale**2``).
"""

import numpy as np

# A row's |a| below this (relative to the largest of its column, at least 1)
# counts as a joint at rest on the path: only its b x term is limited.
_AT_REST = 1e-12
# Share of the falls bound (PathLimits._before_rest) two points before a rest point.
FALLS_SHARE = 0.5


class PathLimits:
    """
    The constraints along one gridded path, ready for many profiles.

    ``path`` is a :class:`constraints.GriddedPath` and ``constraints``
    its constraint objects (first order: a bound on ``x``; second order:
    rows ``lo <= a u + b x <= hi``).  Every bound is proportional to the
    square of the local factor (see the module docstring), so they are
    prepared once for factor 1 and :meth:`profile` only multiplies them.

    A second-order row with ``a != 0`` bounds ``u`` between two lines in
    ``x``: the upper ``u <= alpha x + beta`` (``beta >= 0``) and the lower
    ``u >= gamma x + delta`` (``delta <= 0``); a row with ``a = 0`` (a joint
    at rest on the path) bounds ``x`` alone.  Per step only the lines that
    can bind are kept: a line lying above another for every ``x >= 0``
    never decides the step.
    """

    def __init__(self, path, constraints):
        """Prepare the bounds for factor 1."""
        steps = path.steps
        x_max = np.full(path.s.size, np.inf)
        a, b, lo, hi = [], [], [], []
        for constraint in constraints:
            if constraint.order == 1:
                x_max = np.minimum(x_max, constraint.squared_speed_limit(path))
            else:
                parts = [np.asarray(part, float) for part in constraint.rows(path)]
                if constraint.interpolated:
                    parts = [np.concatenate([part, shifted], axis=1)
                             for part, shifted in zip(parts, _interpolated(parts, steps))]
                for rows, part in zip((a, b, lo, hi), parts):
                    rows.append(part)
        if a:
            a, b, lo, hi = (np.concatenate(rows, axis=1) for rows in (a, b, lo, hi))
        else:
            a = b = lo = hi = np.zeros((path.s.size, 0))
        if np.any(lo > 0.0) or np.any(hi < 0.0):
            raise ValueError('a path-velocity constraint does not allow rest on the path')
        # Relative to each column's largest |a|: below it, a row of a joint at rest.
        scale = np.max(np.abs(a), axis=0, initial=0.0)
        moving = np.abs(a) > _AT_REST * np.maximum(scale, 1.0)[None, :]
        with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
            safe = np.where(moving, a, 1.0)
            # A row at rest: lo <= b x <= hi.
            x_max = np.minimum(x_max, np.min(np.where(~moving & (b > 0.0), hi / b, np.inf),
                                             axis=1, initial=np.inf))
            x_max = np.minimum(x_max, np.min(np.where(~moving & (b < 0.0), lo / b, np.inf),
                                             axis=1, initial=np.inf))
            # A moving row: u between (lo - b x) / a and (hi - b x) / a.
            slope = np.where(moving, -b / safe, np.inf)
            up = np.where(moving, np.where(a > 0.0, hi, lo) / safe, np.inf)
            down = np.where(moving, np.where(a > 0.0, lo, hi) / safe, -np.inf)
            # The lines intersect while (gamma_j - alpha_k) x <= beta_k - delta_j.
            dg = slope[:, None, :] - slope[:, :, None]      # [i, k, j]: lower j - upper k
            both = moving[:, :, None] & moving[:, None, :] & (dg > 0.0)
            gap = np.where(both, up[:, :, None] - down[:, None, :], 0.0)
            pair = np.where(both, gap / np.where(both, dg, 1.0), np.inf)
            self.x_max = np.minimum(x_max, np.min(pair, axis=(1, 2), initial=np.inf))
            # Backward pass: x_i is kept when its hardest braking reaches
            # beta_{i+1}: x + 2 ds (gamma_j x + delta_j) <= beta_{i+1} for
            # every lower line j, i.e. x <= slope_j beta_{i+1} + offset_j.
            two_ds = 2.0 * steps[:, None]
            denominator = 1.0 + two_ds * slope[:-1]
            binds = moving[:-1] & (denominator > 0.0)
            braking = np.where(binds, 1.0 / np.where(binds, denominator, 1.0), np.inf)
            offset = np.where(binds, -two_ds * down[:-1] * braking, np.inf)
            # And the largest acceleration must not take x below 0:
            # x + 2 ds (alpha_k x + beta_k) >= 0, a bound where 1 + 2 ds alpha_k < 0.
            falls = moving[:-1] & (denominator < 0.0)
            self._falls = np.full(path.s.size, np.inf)
            self._falls[:-1] = np.min(
                np.where(falls, two_ds * up[:-1] / np.where(falls, -denominator, 1.0), np.inf),
                axis=1, initial=np.inf)
            self.x_max = np.minimum(self.x_max, self._falls)
        self._braking = _lower_envelopes(braking, offset)
        self._accelerating = _lower_envelopes(slope[:-1], up[:-1])
        self._two_ds = (2.0 * steps).tolist()
        self._before_rest(np.array([path.s.size - 1]))

    def stop_at(self, index):
        """Make the profile rest (``x = 0``) at the grid points ``index`` (a bound of 0 on x)."""
        self.x_max[index] = 0.0
        self._before_rest(np.atleast_1d(index))

    def _before_rest(self, index):
        """
        Keep the point before each rest point ``index`` moving: a step at rest at both ends.

        Where ``1 + 2 ds alpha < 0`` a lower ``x_i`` gives a higher
        ``x_{i+1}``, and at the bound above ``x_{i+1}`` is 0: followed by a
        rest point, a step then has rest at both ends and takes forever (a
        Panda tool line at 0.21 m/s was refused, "no spline meets the
        limits", its profile stuck one grid point before a sharp corner).
        Two points before a rest point the bound is :data:`FALLS_SHARE` of
        it, which leaves ``x_{i+1} >= (1 - FALLS_SHARE) 2 ds beta``.
        """
        before = np.asarray(index, int) - 2
        before = before[before >= 0]
        self.x_max[before] = np.minimum(self.x_max[before], FALLS_SHARE * self._falls[before])

    def profile(self, scale, start=0.0, end=0.0):
        """
        Squared path speed ``x`` (M + 1,) of the fastest traversal of the grid.

        ``scale`` (M + 1,) is the local limit factor; ``start`` and ``end`` are
        the squared path speeds at the ends (0 at rest; the start is lowered
        when it cannot be kept).
        """
        square = scale * scale
        x_max = self.x_max * square
        square = square.tolist()
        beta = _backward(self._braking, square, x_max.tolist(), min(end, x_max[-1]))
        return _forward(self._accelerating, square, self._two_ds, beta, start)


def _interpolated(parts, steps):
    """
    Return rows ``(a, b, lo, hi)`` that hold the rows ``parts`` at the end of each step too.

    Within step ``i`` the path acceleration ``u_i`` is constant and
    ``x_{i+1} = x_i + 2 ds_i u_i``, so a row ``lo <= a u + b x <= hi`` of
    grid point ``i + 1`` with step ``i``'s ``u`` is the row ``(a_{i+1} +
    2 ds_i b_{i+1}) u + b_{i+1} x_i`` of grid point ``i`` (TOPP-RA's
    "interpolation" discretisation; the last point gets an empty row).
    """
    a, b, lo, hi = parts
    shifted_a = np.zeros_like(a)
    shifted_b = np.zeros_like(b)
    shifted_a[:-1] = a[1:] + 2.0 * steps[:, None] * b[1:]
    shifted_b[:-1] = b[1:]
    shifted_lo = np.concatenate([lo[1:], lo[-1:]])
    shifted_hi = np.concatenate([hi[1:], hi[-1:]])
    return shifted_a, shifted_b, shifted_lo, shifted_hi


def _lower_envelopes(slope, offset):
    """
    Per step, the lines ``slope x + offset`` that can be lowest: a list of (slope, offset) lists.

    A line is dropped when another has a slope and an offset no larger (and
    is not the same line), or when it is infinite.  Plain floats, grouped by
    step once: the passes of every profile loop over them.
    """
    finite = np.isfinite(slope) & np.isfinite(offset)
    ds = slope[:, :, None] >= slope[:, None, :]   # [i, k, j]: line j's slope <= line k's
    do = offset[:, :, None] >= offset[:, None, :]
    strictly = (slope[:, :, None] > slope[:, None, :]) | (offset[:, :, None] > offset[:, None, :])
    j_first = np.arange(slope.shape[1])[None, None, :] < np.arange(slope.shape[1])[None, :, None]
    beaten = ds & do & (strictly | j_first) & finite[:, None, :]
    keep = finite & ~np.any(beaten, axis=2)
    bounds = np.concatenate([[0], np.cumsum(np.sum(keep, axis=1))]).tolist()
    lines = list(zip(slope[keep].tolist(), offset[keep].tolist()))
    return [lines[bounds[i]:bounds[i + 1]] for i in range(len(bounds) - 1)]


def _backward(braking, square, x_max, last):
    """beta_i = min(x_max_i, min_j slope_ij beta_{i+1} + offset_ij square_i), from the end."""
    # Plain floats: the recursion is sequential, and per step it is a
    # handful of joints, where numpy's per-call cost would dominate.
    beta = [0.0] * len(x_max)
    b = beta[-1] = last
    for i in range(len(x_max) - 2, -1, -1):
        best = x_max[i]
        scale = square[i]
        for slope, offset in braking[i]:
            value = slope * b + offset * scale
            if value < best:
                best = value
        beta[i] = b = best
    return beta


def _forward(accelerating, square, two_ds, beta, start):
    """Largest acceleration at every step that stays below ``beta``; returns x (M + 1,)."""
    x = [0.0] * len(beta)
    xi = x[0] = min(start, beta[0])
    infinity = float('inf')
    for i in range(len(two_ds)):
        most = infinity
        scale = square[i]
        for slope, offset in accelerating[i]:
            value = offset * scale + slope * xi
            if value < most:
                most = value
        following = xi + two_ds[i] * most
        if following > beta[i + 1]:
            following = beta[i + 1]
        if following < 0.0:
            following = 0.0
        x[i + 1] = xi = following
    return np.array(x)


def joint_acceleration_peaks(path, x):
    """
    Return each joint's largest ``|q''|`` in time (n,) along the profile ``x`` of ``path``.

    ``path`` a :class:`constraints.GriddedPath`.  The path acceleration
    ``u`` is constant on a step, so at both ends of step i the joint
    acceleration is ``q' u_i + q'' x`` (the velocity-dependent part at the
    grid point's speed).
    """
    u = (x[1:] - x[:-1]) / (2.0 * path.steps)
    ends = [path.first[:-1] * u[:, None] + path.second[:-1] * x[:-1, None],
            path.first[1:] * u[:, None] + path.second[1:] * x[1:, None]]
    return np.max(np.abs(np.concatenate(ends)), axis=0, initial=0.0)


def traversal_times(x, steps):
    """Time at every grid point (M + 1,) of the profile ``x`` (``u`` constant per step)."""
    root = np.sqrt(np.maximum(x, 0.0))
    with np.errstate(divide='ignore'):
        return np.concatenate([[0.0], np.cumsum(2.0 * steps / (root[:-1] + root[1:]))])


def path_position(times, x, s, t):
    """
    Return the path coordinate at the times ``t`` of the profile ``x``.

    Within a step ``u`` is constant, so ``s = s_i + sqrt(x_i) tau + u_i tau**2 / 2``
    with ``tau = t - t_i``.
    """
    i = np.clip(np.searchsorted(times, t, side='right') - 1, 0, s.size - 2)
    tau = t - times[i]
    u = (x[i + 1] - x[i]) / (2.0 * (s[i + 1] - s[i]))
    return np.minimum(s[i] + np.sqrt(np.maximum(x[i], 0.0)) * tau + 0.5 * u * tau * tau,
                      s[i + 1])

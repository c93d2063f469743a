"""
The options of one ``plan()`` request, validated once (:class:`PlanOptions`).

``plan()`` is the boundary of the planning core: it turns its keyword
arguments into a :class:`PlanOptions` with :meth:`PlanOptions.from_arguments`,
which raises ValueError with the reason for anything unusable, and passes
that object down unchanged.  Below it nothing parses or re-validates an
option: a function reads the fields it uses.  The tool paths of
``cartesian/`` build one the same way and plan their refined paths with
:func:`dataclasses.replace` copies of it (other tolerances or knot counts),
as joint_trajectory_controller validates its parameters once and hands
the typed struct to its code.

The rules for the inner knots, the smoothing windows and the vibration
frequency of 555 optimal (:mod:`inner_knots`) are stated here, with their
defaults: they decide what the construction is asked to do.
"""

from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from .constraints.torque import TorqueLimit
from .spline.limits import check_boundary_feasible, JointLimits
from .spline.methods import get_method
from .validation import boundary_vector, non_negative, position_limit_vector

# The defaults and bounds of a request, each with its reason; the measurements
# behind them are in doc/methods.md ("Where the constants come from").
TIMINGS = ('uniform', 'fixed', 'optimal')
# Default waypoint_tolerance [rad, or m for a prismatic joint]: four times the
# dead band within which the dynamic arm comes to rest (2.5e-4 rad), so that a
# request that starts at the commanded pose replans cleanly from the measured
# one; 0.057 degrees, below anything taught as two distinct points.
DEFAULT_WAYPOINT_TOLERANCE = 1e-3
BOUNDARY_NAMES = ('start_velocity', 'start_acceleration', 'end_velocity', 'end_acceleration')
# Largest number of inner knots per segment accepted by plan().
MAX_INNER_KNOTS = 8
# The count used when plan() is not given one (555 optimal): with the default
# smoothing as short as more knots, and it shakes the arm least.
DEFAULT_INNER_KNOTS = 4
# The count with torque limits and no smoothing windows (issue 25; see
# inner_knots.TORQUE_GRID_STEPS and doc/inner_knots.md).
TORQUE_INNER_KNOTS = 6
# The moving windows [s] of the speed profile when no vibration frequency is
# given: boxes of 0.3 s and 0.15 s, which together pass at most 9 % of any
# frequency from 3 Hz up, the range where arms' first structural modes sit;
# they make a plan 0.45 s longer (doc/inner_knots.md has the measurements).
DEFAULT_SMOOTHING = (0.3, 0.15)
# plan()'s ``smoothing``: "windows" averages a rest-to-rest profile over
# DEFAULT_SMOOTHING, "none" does not; "auto" (the default) is "windows" except
# with torque limits, whose short moves the windows' 0.45 s would lengthen
# much (vibration_frequency or "windows" smooths them again).
SMOOTHINGS = ('auto', 'windows', 'none')
# plan()'s ``speed_profile``: "smoothed" (the default) is the construction of
# inner_knots (the profile averaged over the smoothing windows, or the
# knots-only optimum when shorter); "time_optimal" the third-order profile of
# time_optimal.py, followed by a C4 spline: shorter, and it shakes the arm more.
SPEED_PROFILES = ('smoothed', 'time_optimal')
# "time_optimal" plans at most this many waypoints (after merging): its
# sequential LPs grow with the path (0.46 s for 100 waypoints of 7 joints, 1.2 s
# for 200, against 0.04 s and 0.08 s for "smoothed"; the node plans on one worker).
MAX_TIME_OPTIMAL_WAYPOINTS = 200
# A vibration frequency above this [Hz] is refused (its window would be
# shorter than a servo cycle of 1 ms).
MAX_VIBRATION_FREQUENCY = 1000.0
# A vibration frequency below this [Hz] (but 0, not used) is refused: its
# windows of 1/f would be over 10 s, slower than any arm's structural mode,
# and at 1e-6 Hz a 1 rad move was planned to last 2e6 s (helper-89).
MIN_VIBRATION_FREQUENCY = 0.1


def default_inner_knots(method, timing):
    """Return the count ``inner_knots`` None stands for: :data:`DEFAULT_INNER_KNOTS` or 0."""
    return DEFAULT_INNER_KNOTS if (method, timing) == ('555', 'optimal') else 0


def inner_knot_count(value, method, timing):
    """
    Validate the ``inner_knots`` argument of plan(); return it as an int.

    None (the default) is :data:`DEFAULT_INNER_KNOTS` for method 555 with
    timing "optimal" and 0 otherwise (:func:`default_inner_knots`).  Otherwise an integer from 0 to
    :data:`MAX_INNER_KNOTS`; a non-zero count needs method 555 with timing
    "optimal" (the only combination that uses it).
    """
    if value is None:
        return default_inner_knots(method, timing)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f'inner_knots must be an integer, got {value!r}')
    value = int(value)
    if not 0 <= value <= MAX_INNER_KNOTS:
        raise ValueError(f'inner_knots must be between 0 and {MAX_INNER_KNOTS}, got {value}')
    if value and (method != '555' or timing != 'optimal'):
        raise ValueError(f'inner_knots = {value} needs method "555" with timing "optimal", '
                         f'got method {method!r} with timing {timing!r}')
    return value


def vibration_frequency_value(value, inner_knots):
    """
    Validate the ``vibration_frequency`` argument of plan() [Hz]; return it as a float.

    None and 0 mean "not given" (the default smoothing).  Otherwise a finite
    number in [:data:`MIN_VIBRATION_FREQUENCY`, :data:`MAX_VIBRATION_FREQUENCY`],
    which needs inner knots (555 optimal): the other timings have no profile
    to shape.
    """
    if value is None:
        return 0.0
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f'vibration_frequency must be a number [Hz], got {type(value).__name__}')
    value = float(value)
    if not (value == 0.0 or MIN_VIBRATION_FREQUENCY <= value <= MAX_VIBRATION_FREQUENCY):
        raise ValueError(f'vibration_frequency must be 0 (not used) or between '
                         f'{MIN_VIBRATION_FREQUENCY:g} and {MAX_VIBRATION_FREQUENCY:g} Hz, got '
                         f'{value:.6g}')
    if value and not inner_knots:
        raise ValueError('vibration_frequency needs method "555" with timing "optimal" and '
                         'inner_knots not 0: the other timings have no speed profile to shape')
    return value


def smoothing_value(value, vibration_frequency, inner_knots):
    """
    Validate the ``smoothing`` argument of plan(); return one of :data:`SMOOTHINGS`.

    None means "auto".  "windows" and "none" need inner knots (555 optimal:
    the other timings have no profile to average), and a
    ``vibration_frequency`` sets its own windows, so it needs "auto": either
    would otherwise be silently ignored.
    """
    if value is None:
        return 'auto'
    if not isinstance(value, str) or value not in SMOOTHINGS:
        shown = repr(value)[:40] if isinstance(value, str) else type(value).__name__
        raise ValueError(f'smoothing must be one of {list(SMOOTHINGS)}, got {shown}')
    if value != 'auto' and not inner_knots:
        raise ValueError(f'smoothing {value!r} needs method "555" with timing "optimal" and '
                         'inner_knots not 0: the other timings have no speed profile to average')
    if value != 'auto' and vibration_frequency:
        raise ValueError(f'smoothing {value!r} with vibration_frequency '
                         f'{vibration_frequency:g} Hz: the frequency sets the windows itself '
                         '(two of 1 / f); use smoothing "auto" with it')
    return value


def speed_profile_value(value, method, timing, inner_knots_given=False, smoothing='auto'):
    """
    Validate the ``speed_profile`` argument of plan(); return one of :data:`SPEED_PROFILES`.

    None means "smoothed".  "time_optimal" needs method 555 with timing
    "optimal", and no option it would silently ignore: an ``inner_knots``
    count (its knots follow the profile) or a ``smoothing`` other than
    "auto" (it has no smoothing windows; a ``vibration_frequency`` cancels
    the ringing of the mode after the stop instead, :mod:`residual_vibration`).  The
    ``durations`` of timing "optimal" are only a warm start of the
    optimiser: it does not need one (plan() says so), and its fallback to
    "smoothed" uses them.  Its limits are timing "optimal"'s (velocity and
    acceleration, jerk where given), the waypoint count
    :func:`check_time_optimal_waypoints`'.
    """
    if value is None:
        return 'smoothed'
    if not isinstance(value, str) or value not in SPEED_PROFILES:
        shown = repr(value)[:40] if isinstance(value, str) else type(value).__name__
        raise ValueError(f'speed_profile must be one of {list(SPEED_PROFILES)}, got {shown}')
    if value == 'smoothed':
        return value
    if (method, timing) != ('555', 'optimal'):
        raise ValueError(f'speed_profile {value!r} needs method "555" with timing "optimal", '
                         f'got method {method!r} with timing {timing!r}')
    if inner_knots_given:
        raise ValueError(f'speed_profile {value!r} places its own knots (every '
                         'few milliseconds of its profile): leave inner_knots unset (auto)')
    if smoothing != 'auto':
        raise ValueError(f'speed_profile {value!r} has no smoothing windows: smoothing '
                         f'{smoothing!r} would be ignored; use speed_profile "smoothed" with it')
    return value


def check_time_optimal_waypoints(n_points):
    """Raise ValueError above :data:`MAX_TIME_OPTIMAL_WAYPOINTS` merged waypoints."""
    if n_points > MAX_TIME_OPTIMAL_WAYPOINTS:
        raise ValueError(f'speed_profile "time_optimal" plans at most '
                         f'{MAX_TIME_OPTIMAL_WAYPOINTS} waypoints, got {n_points}: its linear '
                         'programs grow with the path; use speed_profile "smoothed"')


def smoothing_windows(vibration_frequency, smoothing='windows', torque_limited=False):
    """
    Return the moving windows [s] of the speed profile for a ``vibration_frequency`` [Hz].

    Given ``f`` (not 0): two boxes of ``1 / f``, a double zero of the path
    acceleration's spectrum at ``f`` (and at its multiples), so that the zero
    survives the small change of time scale of the exact limits and the
    mode's damping; it costs about one more period ``1 / f`` than a single
    box.  Not given: the boxes of :data:`DEFAULT_SMOOTHING` for
    ``smoothing`` "windows", and for "auto" unless ``torque_limited``; none
    otherwise (:data:`SMOOTHINGS`).
    """
    if vibration_frequency:
        return (1.0 / vibration_frequency,) * 2
    if smoothing == 'none' or (smoothing == 'auto' and torque_limited):
        return ()
    return DEFAULT_SMOOTHING


def torque_without_windows(torque, windows):
    """
    Return True for torque limits (``torque`` not None) with no smoothing ``windows``.

    Such a speed profile keeps its jumps of acceleration, and three things
    follow from that one condition: its own count of inner knots
    (:data:`TORQUE_INNER_KNOTS`), shorter pieces in the construction
    (``inner_knots.TORQUE_RAMP_PIECES``), and no knots-only rival in plan().
    """
    return torque is not None and not windows


def boundary_vectors(values, n_joints):
    """
    Return the four boundary vectors of a request, each (n_joints,) finite (ValueError).

    ``values``: start velocity, start acceleration, end velocity, end
    acceleration (:data:`BOUNDARY_NAMES`), None for zeros.
    """
    return tuple(boundary_vector(name, value, n_joints)
                 for name, value in zip(BOUNDARY_NAMES, values))


def torque_limit(max_torque, inverse_dynamics, n_joints, boundary):
    """
    Return the :class:`~.torque.TorqueLimit` of a request, or None (``max_torque`` None).

    ValueError for unusable limits, and for a ``boundary`` (the four
    vectors) that is not at rest: torque limits are planned rest to rest.
    """
    if max_torque is None:
        return None
    torque = TorqueLimit(max_torque, inverse_dynamics, n_joints)
    if any(np.any(b) for b in boundary):
        raise ValueError('torque limits are planned rest to rest: the boundary velocities '
                         'and accelerations must be zero')
    return torque


@dataclass(frozen=True)
class PlanOptions:
    """
    Every option of a ``plan()`` request but the waypoints and durations, validated.

    Build it with :meth:`from_arguments` (``plan()``'s keyword arguments),
    or with :meth:`from_validated` (settings a caller validated once, such
    as the planner node); the fields are then what the planning code reads,
    as they are:

    * ``method`` ("445", "434" or "555") and ``timing`` (:data:`TIMINGS`);
    * ``limits``: the :class:`~.limits.JointLimits`, or None (only "fixed"
      timing plans without them);
    * ``boundary``: start velocity, start acceleration, end velocity, end
      acceleration, each (n,) (zeros at rest);
    * ``waypoint_tolerance`` [rad or m], >= 0;
    * ``min_position``, ``max_position``: (n,) position limits (+-inf where
      none), or None when neither was given;
    * ``inner_knots``: the count :func:`inner_knot_count` gives (0: knots
      at the waypoints only), ``inner_knots_auto`` whether the caller left
      it to plan() (then :attr:`planned_inner_knots` may differ);
    * ``vibration_frequency`` [Hz] (0: not given), ``smoothing``
      (:data:`SMOOTHINGS`) and ``windows`` [s], the speed profile's moving
      windows they give (:func:`smoothing_windows`);
    * ``torque``: the :class:`~.torque.TorqueLimit`, or None;
    * ``speed_profile`` (:data:`SPEED_PROFILES`);
    * ``joint_names``: the joints' names for the errors (position limits),
      or None (their indices only).
    """

    method: str
    timing: str
    limits: Optional[JointLimits]
    boundary: Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    waypoint_tolerance: float
    min_position: Optional[np.ndarray]
    max_position: Optional[np.ndarray]
    inner_knots: int
    inner_knots_auto: bool
    vibration_frequency: float
    smoothing: str
    windows: Tuple[float, ...]
    torque: Optional[TorqueLimit]
    speed_profile: str = 'smoothed'
    joint_names: Optional[Tuple[str, ...]] = None

    @classmethod
    def from_arguments(cls, n_joints, method='445', timing='uniform', max_velocity=None,
                       max_acceleration=None, max_jerk=None, start_velocity=None,
                       start_acceleration=None, end_velocity=None, end_acceleration=None,
                       waypoint_tolerance=DEFAULT_WAYPOINT_TOLERANCE, min_position=None,
                       max_position=None, inner_knots=None, vibration_frequency=None,
                       max_torque=None, inverse_dynamics=None, smoothing=None,
                       speed_profile=None):
        """
        Validate ``plan()``'s keyword arguments for ``n_joints`` joints (ValueError: the reason).

        The arguments are those of :func:`~.planner.plan`, with its defaults;
        the checks and their texts are the ones plan() has always made.
        """
        if not isinstance(timing, str) or timing not in TIMINGS:
            raise ValueError(f'unknown timing {timing!r}: expected one of {TIMINGS}')
        method = get_method(method).name
        knots = inner_knot_count(inner_knots, method, timing)
        vibration = vibration_frequency_value(vibration_frequency, knots)
        if (max_torque is None) != (inverse_dynamics is None):
            raise ValueError('max_torque and inverse_dynamics must be given together')
        smoothing = smoothing_value(smoothing, vibration, knots)
        profile = speed_profile_value(speed_profile, method, timing, inner_knots is not None,
                                      smoothing)
        windows = smoothing_windows(vibration, smoothing, max_torque is not None)
        boundary = boundary_vectors((start_velocity, start_acceleration, end_velocity,
                                     end_acceleration), n_joints)
        torque = torque_limit(max_torque, inverse_dynamics, n_joints, boundary)
        tolerance = non_negative('waypoint_tolerance', waypoint_tolerance)
        limits = None
        if max_velocity is not None or max_acceleration is not None or max_jerk is not None:
            if max_velocity is None or max_acceleration is None:
                raise ValueError('max_velocity and max_acceleration must be given together')
            limits = JointLimits.from_user(n_joints, max_velocity, max_acceleration, max_jerk)
            check_boundary_feasible(limits, *boundary)
        elif timing != 'fixed':
            raise ValueError(f'timing={timing!r} needs max_velocity and max_acceleration')
        low = high = None
        if min_position is not None or max_position is not None:
            low = position_limit_vector('min_position', min_position, n_joints, -np.inf)
            high = position_limit_vector('max_position', max_position, n_joints, np.inf)
            bad = np.flatnonzero(low > high)
            if bad.size:
                j = int(bad[0])
                raise ValueError(f'min_position[{j}] = {low[j]} is above max_position[{j}] = '
                                 f'{high[j]}')
        return cls(method, timing, limits, boundary, tolerance, low, high, knots,
                   inner_knots is None, vibration, smoothing, windows, torque, profile)

    @classmethod
    def from_validated(cls, n_joints, method, timing, max_velocity, max_acceleration,
                       max_jerk=None, boundary=(None,) * 4,
                       waypoint_tolerance=DEFAULT_WAYPOINT_TOLERANCE, inner_knots=None,
                       vibration_frequency=0.0, smoothing='auto', max_torque=None,
                       inverse_dynamics=None, speed_profile='smoothed', min_position=None,
                       max_position=None, joint_names=None):
        """
        Build the options of one request whose planner settings were validated once already.

        For a caller with its own boundary that validates its settings
        once, as :meth:`from_arguments` would (the planner node's parameter
        layer, ``service/planner_config.py``): ``method`` (a name of
        :data:`~.methods.METHODS`), ``timing``, the limits (``max_velocity``,
        ``max_acceleration`` positive and finite, ``max_jerk`` positive, inf
        for none, or None), ``waypoint_tolerance``, ``inner_knots`` (None =
        auto: :func:`default_inner_knots`), ``vibration_frequency`` (0 = not
        given), ``smoothing`` and ``speed_profile`` are taken as they are.  What comes with the
        request is checked, with :meth:`from_arguments`' texts: the
        ``boundary`` (start velocity, start acceleration, end velocity, end
        acceleration; None = zeros) of ``n_joints`` (the request's columns;
        limits of another length are refused as plan() refuses them), within
        the limits, and zero with torque limits (``max_torque`` with
        ``inverse_dynamics``, checked by :class:`~.torque.TorqueLimit`).
        ``min_position``, ``max_position``: the validated position limits
        ((n,) each, or None: that side unbounded; both None: none), and
        ``joint_names`` to name the joint in their errors.
        """
        with np.errstate(over='ignore', invalid='ignore', divide='ignore', under='ignore'):
            knots = (default_inner_knots(method, timing) if inner_knots is None
                     else int(inner_knots))
            vibration = float(vibration_frequency)
            windows = smoothing_windows(vibration, smoothing, max_torque is not None)
            boundary = boundary_vectors(boundary, n_joints)
            torque = torque_limit(max_torque, inverse_dynamics, n_joints, boundary)
            jerk = () if max_jerk is None else (max_jerk,)
            if any(len(values) != n_joints for values in (max_velocity, max_acceleration) + jerk):
                # A request of another number of joints: plan()'s own refusal.
                limits = JointLimits.from_user(n_joints, max_velocity, max_acceleration,
                                               max_jerk)
            else:
                limits = JointLimits(np.array(max_velocity, dtype=float),
                                     np.array(max_acceleration, dtype=float),
                                     np.full(n_joints, np.inf) if max_jerk is None
                                     else np.array(max_jerk, dtype=float))
            names = None if joint_names is None or len(joint_names) != n_joints else joint_names
            check_boundary_feasible(limits, *boundary, names)
            low = high = None
            if min_position is not None or max_position is not None:
                low = position_limit_vector('min_position', min_position, n_joints, -np.inf)
                high = position_limit_vector('max_position', max_position, n_joints, np.inf)
        return cls(method, timing, limits, boundary, float(waypoint_tolerance), low, high, knots,
                   inner_knots is None, vibration, smoothing, windows, torque, speed_profile,
                   None if joint_names is None else tuple(joint_names))

    @property
    def rest(self):
        """Return True when every boundary value is zero: the request starts and ends at rest."""
        return not any(np.any(b) for b in self.boundary)

    @property
    def torque_without_windows(self):
        """Return :func:`torque_without_windows` of the options' torque and windows."""
        return torque_without_windows(self.torque, self.windows)

    @property
    def planned_inner_knots(self):
        """
        Return the inner knots per segment that plan() places.

        ``inner_knots``; left to plan() (``inner_knots_auto``) with torque
        limits and no smoothing windows, :data:`TORQUE_INNER_KNOTS`.
        """
        if self.inner_knots_auto and self.inner_knots and self.torque_without_windows:
            return TORQUE_INNER_KNOTS
        return self.inner_knots

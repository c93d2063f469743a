"""
How long a tool path's refinement may run: ``max_refinement_time``.

The refinement of a tool request (knots inserted until the tool stays
within its tolerances: :mod:`tool_paths`, :mod:`tool_lines`) runs for as
many rounds as ``max_inserted`` allows.  At a tight tolerance with a large
``max_inserted`` that can be minutes (a 50-pose circle at 1e-7 m, 555
optimal, ``max_inserted`` 10 000: 197 s on the planar arm), while the
planner node serves nothing else.  A :class:`RefinementClock` is read
between rounds: past its time, the refinement stops with
:class:`RefinementTimeout`, saying how far it got, as it does at
``max_inserted`` (MoveIt's ``allowed_planning_time`` plays the same part).
A round that has started is not interrupted, so the refinement can run
over by one round.  The steps after the rounds that only shorten a plan
already within its tolerances (the third-order profile's re-timing, the
pieces split for the tool speed, the refined path's inner knots) are
skipped once the time is up, and the plan says so (:data:`SKIPPED`).
"""

import time

# optimizer['refinement_time'] of a plan whose last, optional steps were skipped.
SKIPPED = 'max_refinement_time reached: the steps that only shorten the plan were skipped'


class RefinementTimeout(ValueError):
    """The refinement ran past ``max_refinement_time``, the tool not yet within its tolerances."""


class RefinementClock:
    """The time a refinement started, and how long it may run (``seconds``; None: no limit)."""

    def __init__(self, seconds=None):
        """Start the clock; ``seconds`` None or 0 means no limit (ValueError when negative)."""
        if seconds is not None and not seconds >= 0.0:
            raise ValueError(f'max_refinement_time = {seconds}: must be a non-negative '
                             'number of seconds (0 or None: no limit)')
        self.seconds = seconds or None
        self.started = time.monotonic()

    def elapsed(self):
        """Seconds since the clock started."""
        return time.monotonic() - self.started

    def expired(self):
        """Whether the time is up (never without a limit)."""
        return self.seconds is not None and self.elapsed() > self.seconds

    def check(self, stopped):
        """
        Raise :class:`RefinementTimeout` when the time is up; ``stopped()`` says where it stood.

        ``stopped`` is called only then, and returns the rest of the message
        (what was inserted, how far the tool still is from its tolerance).
        """
        if self.expired():
            raise RefinementTimeout(
                f'tool path refinement stopped after {self.elapsed():.3g} s, past '
                f'max_refinement_time ({self.seconds:g} s): {stopped()}')

"""
The three kinds of constraint along a path: first, second and third order (issues 24, 25, 38).

Along a gridded joint path ``q(s)`` traversed at path speed ``sdot``, with
``x = sdot**2`` and ``u = sddot`` (:mod:`path_velocity`), every limit this
package holds is one of three kinds at each grid point ``i``:

* first order, a bound on the squared path speed alone: ``x <= x_max_i``
  (joint velocity ``|q'_j| sdot <= v_j``; tool speed ``|p'(s)| sdot <= v``);
* second order, rows ``lo <= a u + b x <= hi`` (joint acceleration
  ``q' u + q'' x``; tool acceleration ``|p' u + p'' x| <= A``, held by a
  polygon of such rows; joint torque ``M q' u + (M q'' + C(q, q') q') x + g``,
  whose constant ``g`` is moved into ``lo`` and ``hi``);
* third order, a bound on the time derivative of such a row (joint jerk
  ``|d/dt (q' u + q'' x)| <= j``), which the third-order profiles hold
  (:mod:`jerk_profile`, :mod:`smooth_profile`).

The first two are the canonical forms of Pham & Pham's TOPP-RA (their "first-order"
and "canonical linear second-order" constraints); each object here gives its
bounds per grid point and knows nothing of the solver.  Rows must allow rest
(``lo <= 0 <= hi``): a path that needs more than the limit to be held still
at some point (a torque that gravity alone exceeds) cannot be traversed at
any speed, and the object says so with a ValueError naming the grid point.

A time scaling by the local factor ``lambda`` (velocity limits times
``lambda``, accelerations times ``lambda**2``) multiplies ``x_max``, ``lo``
and ``hi`` by ``lambda**2``; :class:`path_velocity.PathLimits` applies it.
"""


class SpeedConstraint:
    """A first-order constraint: ``x <= squared_speed_limit(path)`` at every grid point."""

    order = 1

    def squared_speed_limit(self, path):
        """Return the largest squared path speed (M + 1,) at every grid point (inf: none)."""
        raise NotImplementedError


class AccelerationConstraint:
    """A second-order constraint: rows ``lo <= a u + b x <= hi`` at every grid point."""

    order = 2
    # Whether the rows also hold at the end of each grid step with its path
    # acceleration (path_velocity._interpolated), not only at the grid points.
    interpolated = False

    def rows(self, path):
        """Return ``(a, b, lo, hi)``, each (M + 1, k), with ``lo <= 0 <= hi``."""
        raise NotImplementedError


class JerkConstraint:
    """
    A third-order constraint: ``|sdot (c_x x + c_u u + c_du du/ds)| <= bound`` at every grid point.

    The time derivative of a second-order row's ``a u + b x`` along the
    path, with ``du/dt = sdot du/ds`` and ``dx/dt = 2 sdot u``; a time
    scaling by ``lambda`` multiplies ``bound`` by ``lambda**3``.
    """

    order = 3

    def terms(self, path):
        """Return ``(c_x, c_u, c_du, bound)``, each (M + 1, k), ``bound > 0`` (inf: none)."""
        raise NotImplementedError

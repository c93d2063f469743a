"""
The latest ``joint_states`` of each joint set: an arm's beside a gripper's.

A robot often has more than one publisher on ``joint_states`` (an arm's
driver and a gripper's, each naming only its own joints, as
joint_state_broadcasters of two controller managers do).  Keeping only the
latest message, the planner saw "no joint_states of the planned joints"
whenever the gripper's came last: a goal's start check was skipped (the arm
jumped 1 rad, helper-88), ``start_from_current_state`` failed at random, and
the feedback had no measured state.  Here the latest message of each joint
set (its tuple of names) is kept, the newest that names all the planned
joints is the one read (its stamp gives its age), like MoveIt's
CurrentStateMonitor reads the joints it needs from whichever message last
named them, but a message whole: a position and velocity always of one
instant.  The sets kept are bounded (:data:`MAX_JOINT_SETS`, the oldest
dropped), so a publisher of ever new names cannot grow the node's memory.
The executor takes messages while the planning worker reads: each message
replaces the kept sets by a new tuple (one assignment), never changes one
being read.
"""

# Joint sets kept (distinct tuples of names on joint_states); the least
# recently received is dropped beyond it.
MAX_JOINT_SETS = 8


class LatestJointStates:
    """The latest message of each set of joint names received on ``joint_states``."""

    def __init__(self, max_sets=MAX_JOINT_SETS):
        """Keep up to ``max_sets`` joint sets."""
        self._sets = ()     # (names tuple, latest message), the newest last
        self._max_sets = int(max_sets)

    def take(self, msg):
        """Keep ``msg`` as the latest of its joint set (the newest set last)."""
        key = tuple(msg.name)
        kept = tuple(item for item in self._sets if item[0] != key)
        self._sets = (kept + ((key, msg),))[-self._max_sets:]

    def latest(self):
        """Return the latest message received (any joint set), or None."""
        sets = self._sets
        return sets[-1][1] if sets else None

    def covering(self, names):
        """Return the latest message that names every joint of ``names``, or None."""
        wanted = set(names)
        for key, msg in reversed(self._sets):
            if wanted.issubset(key):
                return msg
        return None

    def names_seen(self):
        """Return every joint name of the kept messages, the oldest set's first."""
        seen = {}
        for key, _ in self._sets:
            seen.update(dict.fromkeys(key))
        return list(seen)


__all__ = ['LatestJointStates', 'MAX_JOINT_SETS']

"""
Hypothesis example counts: moderate by default, many more on request.

A property test gives its count as ``examples(n)``.  With
SPLINES445_HYPOTHESIS_PROFILE=long (conftest.py, which then also draws fresh
examples on every run) the count is multiplied by :data:`LONG_FACTOR`, at
most :data:`LONG_EXAMPLES`: 2000 for the fast tests, 30 times their own
count for the slow ones.  (A count given to ``settings`` directly would
override the profile's.)
"""

import os

LONG_FACTOR = 30
LONG_EXAMPLES = 2000


def examples(count):
    """Return ``count``, or up to :data:`LONG_FACTOR` times it under the long profile."""
    if os.environ.get('SPLINES445_HYPOTHESIS_PROFILE') == 'long':
        return min(LONG_EXAMPLES, LONG_FACTOR * count)
    return count

"""LatestJointStates against the whole history of messages, read by a rule written here."""

import os
from types import SimpleNamespace

from example_counts import examples
from hypothesis import given, settings
import hypothesis.strategies as st
from splines445_ros.service.joint_states import LatestJointStates, MAX_JOINT_SETS

EXAMPLES = int(os.environ.get('SPLINES445_PROPERTY_EXAMPLES', str(examples(200))))

JOINTS = ('a', 'b', 'c', 'd', 'e')
name_sets = st.lists(st.sampled_from(JOINTS), min_size=0, max_size=4, unique=True)


def expected_covering(history, names, max_sets):
    """
    Return the newest message naming every joint of ``names`` among the kept sets.

    Kept: the ``max_sets`` joint sets (name tuples, in their order) received
    most recently, each at its newest message.
    """
    last_seen = {}
    for i, msg in enumerate(history):
        last_seen[tuple(msg.name)] = i
    kept = sorted(last_seen, key=last_seen.get)[-max_sets:]
    found = [last_seen[key] for key in kept if set(names) <= set(key)]
    return history[max(found)] if found else None


@settings(max_examples=EXAMPLES, deadline=None)
@given(sets=st.lists(name_sets, min_size=0, max_size=40),
       asked=st.lists(name_sets, min_size=1, max_size=5),
       max_sets=st.integers(1, MAX_JOINT_SETS))
def test_the_newest_message_covering_the_names_among_the_kept_sets(sets, asked, max_sets):
    states = LatestJointStates(max_sets)
    history = []
    for i, names in enumerate(sets):
        msg = SimpleNamespace(name=list(names), position=[float(i)] * len(names))
        history.append(msg)
        states.take(msg)
        for names_asked in asked:
            expected = expected_covering(history, names_asked, max_sets)
            assert states.covering(names_asked) is expected
        assert states.latest() is msg
    if not history:
        assert states.latest() is None and states.names_seen() == []


def test_an_arms_message_is_read_past_a_grippers_newer_ones():
    states = LatestJointStates()
    arm = SimpleNamespace(name=['j1', 'j2'], position=[0.0, 1.0])
    states.take(arm)
    for _ in range(100):
        states.take(SimpleNamespace(name=['finger'], position=[0.01]))
    assert states.covering(['j2', 'j1']) is arm
    assert states.covering(['j1', 'finger']) is None
    assert states.names_seen() == ['j1', 'j2', 'finger']


def test_ever_new_joint_sets_keep_only_the_newest():
    states = LatestJointStates()
    for i in range(1000):
        states.take(SimpleNamespace(name=[f'joint_{i}'], position=[0.0]))
    assert len(states.names_seen()) == MAX_JOINT_SETS
    assert states.covering(['joint_999']) is not None
    assert states.covering(['joint_0']) is None

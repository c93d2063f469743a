"""
The tip of a robot's chain: the default tool frame, like MoveIt's tip link (no rclpy).

:func:`chain_tips` returns the candidates for the tool frame of a set of
planned joints of a :class:`~splines445_ros.robot.robot_model.RobotModel`:

1. the *last* planned joint is the one every other planned joint lies on
   the way to (from the world); planned joints on separate branches (two
   arms, say) have no last joint and so no tip;
2. the candidates are the bodies (URDF links) rigidly attached to that
   joint's body, through fixed joints only, that have no rigidly attached
   body beyond them: the ends of the chain.

One candidate is the tip (xArm7: ``link_eef``; the Panda's arm joints:
``panda_hand_tcp``); several make the tip ambiguous (the UR5's
``wrist_3_link`` carries both ``ee_link`` and ``tool0``), and the caller
asks the user to choose, listing them.
"""


def chain_tips(robot, joints):
    """
    Return ``(candidates, reason)`` for the tool frame of JointInfo ``joints``.

    ``candidates`` is a tuple of body names, in the model's order (empty
    when there is no tip); ``reason`` says why when there is none.
    """
    mj, m = robot.mujoco, robot.model
    if not joints:
        return (), 'no joints are planned'
    bodies = [int(m.jnt_bodyid[j.joint_id]) for j in joints]
    paths = {b: set(_ancestors(m, b)) for b in bodies}
    last = [b for b in bodies if all(other in paths[b] for other in bodies)]
    if not last:
        return (), ('the planned joints are not on one chain from the world (no joint has '
                    'all the others on its way)')
    children = {}
    for b in range(1, m.nbody):
        children.setdefault(int(m.body_parentid[b]), []).append(b)
    rigid_ends = []
    stack = [last[0]]
    while stack:
        body = stack.pop()
        rigid = [c for c in children.get(body, ()) if int(m.body_jntnum[c]) == 0]
        if rigid:
            stack.extend(rigid)
        else:
            rigid_ends.append(body)
    names = tuple(mj.mj_id2name(m, mj.mjtObj.mjOBJ_BODY, b) or f'body{b}'
                  for b in sorted(rigid_ends))
    return names, ''


def _ancestors(model, body):
    """Return the bodies from ``body`` (itself included) up to the world (excluded)."""
    chain = []
    while body != 0:
        chain.append(body)
        body = int(model.body_parentid[body])
    return chain

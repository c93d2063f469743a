"""
The one place that imports MuJoCo: :func:`import_mujoco`, with an installation hint.

A leaf module (it imports nothing from the package), so every module of
``arm`` that needs MuJoCo imports it from here and no two of them have to
import each other.
"""


def import_mujoco():
    """Return the ``mujoco`` module (ValueError saying how to install it when missing)."""
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ValueError('this needs the mujoco Python package (pip install '
                         'mujoco-core==4.0.0, or the rosdep key python3-mujoco-pip)') from exc
    return mujoco

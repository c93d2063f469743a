"""The ``main()`` shared by the executables: spin one node, exit cleanly on Ctrl-C."""

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException


def run_node(node_class, args=None):
    """Spin a ``node_class()`` until Ctrl-C or shutdown; exit 2 on invalid parameters."""
    rclpy.init(args=args)
    node = None
    try:
        try:
            node = node_class()
        except (ValueError, ParameterException) as exc:
            # Only the start-up parameters: an error while spinning is not theirs.  rclpy
            # refuses a value of another type for a fixed-type parameter itself
            # (-p max_trajectory_points:="'5'"): a traceback before (helper-78).
            print(f'{node_class.__name__}: invalid parameters: {exc}')
            raise SystemExit(2)
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()

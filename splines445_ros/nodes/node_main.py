"""The ``main()`` shared by the executables: spin one node, exit cleanly on Ctrl-C."""

import rclpy
from rclpy.executors import ExternalShutdownException


def run_node(node_class, args=None):
    """Spin a ``node_class()`` until Ctrl-C or shutdown; exit 2 on invalid parameters."""
    rclpy.init(args=args)
    node = None
    try:
        try:
            node = node_class()
        except ValueError as exc:
            # Only the start-up parameters: an error while spinning is not theirs.
            print(f'{node_class.__name__}: invalid parameters: {exc}')
            raise SystemExit(2)
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()

"""Spins a test node until SIGINT, then destroys it, so that DDS releases its shared memory
(the tests check /dev/shm is left as it was)."""

import rclpy
from rclpy.executors import ExternalShutdownException


def spin_until_sigint(node) -> None:
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()

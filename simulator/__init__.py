"""The Cyborg simulator: a rosbridge v2 websocket server that behaves like the robot.

Plain Python (no Django): ``SimRobot`` is the asyncio server, ``SimThread`` runs one in a
background thread. ``python -m simulator`` is the command-line entry point.
"""

from .harness import SimThread
from .robot import SimRobot

__all__ = ["SimRobot", "SimThread"]

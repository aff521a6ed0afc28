"""The robot's uplink agent: it dials the server, so nothing on the robot listens beyond loopback.

Runs on the robot's own computer (Ubuntu 16.04, system Python 3.5) with the standard library only:
keep this package free of f-strings, variable annotations, async generators and anything newer.
"""

__version__ = "1.0"

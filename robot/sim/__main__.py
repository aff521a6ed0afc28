"""``python -m robot.sim``: the simulator without Django (benches, scripts). Same flags as ``manage.py simrobot``."""

import argparse

from .cli import add_arguments, run

parser = argparse.ArgumentParser(prog="python -m robot.sim", description=__doc__)
add_arguments(parser)
run(vars(parser.parse_args()))

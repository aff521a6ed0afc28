"""``python -m simulator``: run the Cyborg simulator (rosbridge v2 + web_video_server look-alike)."""

import argparse

from .cli import add_arguments, run

parser = argparse.ArgumentParser(prog="python -m simulator", description=__doc__)
add_arguments(parser)
run(vars(parser.parse_args()))

"""``python manage.py simrobot``: run the robot simulator (rosbridge v2 + web_video_server look-alike)."""

from typing import Any

from django.core.management.base import BaseCommand, CommandParser

from robot.sim.cli import add_arguments, run


class Command(BaseCommand):
    help = "Run the Cyborg simulator: a rosbridge v2 websocket server that behaves like the robot."

    def add_arguments(self, parser: CommandParser) -> None:
        add_arguments(parser)

    def handle(self, *args: Any, **opts: Any) -> None:
        run(opts)

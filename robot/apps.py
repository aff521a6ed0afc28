from typing import Any

from django.apps import AppConfig
from django.core import checks
from django.core.checks import CheckMessage


class RobotConfig(AppConfig):
    name = "robot"
    default_auto_field = "django.db.models.BigAutoField"

    def ready(self) -> None:
        checks.register(check_robot_settings)
        from django.conf import settings

        import cyborg_site.checks  # noqa: F401  (the site's own: the secret key)

        # Wherever the link runs: the map renderer, the goal tracker, where the robot is,
        # the state machine graph and the diagnostics.
        from robot.audio import link as audio
        from robot.audio.talk import end_all_talk
        from robot.commands.pipeline import Gate, install_gate
        from robot.estop import stop as estop
        from robot.estop.latch import ensure_released
        from robot.estop.rule import declaration
        from robot.introspection import tracking
        from robot.link import watching
        from robot.link.hosting import register_background
        from robot.link.releases import LINK_HOOKS
        from robot.navigation import broadcast, handlers, whereabouts
        from robot.navigation.goals import cancel_every_goal
        from robot.overlays import link as overlays
        from robot.teleop.driving import announce_release, free_for_the_stop
        from robot.uplink import hosting as uplink

        LINK_HOOKS.register_check()
        # The features' own parts of the E-STOP.
        estop.register_step("drive_lock", free_for_the_stop)
        estop.register_step("talk", end_all_talk)
        estop.register_step("cancel_navigation", cancel_every_goal)
        estop.on_release(announce_release)
        install_gate(Gate(declaration, ensure_released))
        checks.register(check_estop_steps)
        audio.install()  # microphone relay and speaker format wherever the link runs
        overlays.install()
        watching.install()  # any topic a page opens: leases, echo, listing and rates
        tracking.install()
        handlers.install()
        whereabouts.install()
        if settings.UPLINK:  # the robot's agent connects to the process that hosts the link
            register_background("uplink", uplink.serve_uplink)

        broadcast.connect()


def check_estop_steps(app_configs: Any, **kwargs: Any) -> list[CheckMessage]:
    from robot.estop.stop import missing_steps

    return [checks.Error(f"the E-STOP has no {name!r} step installed", id="robot.E005") for name in missing_steps()]


def check_robot_settings(app_configs: Any, **kwargs: Any) -> list[CheckMessage]:
    from django.conf import settings

    from robot import interface

    errors: list[CheckMessage] = []
    if not settings.ROSBRIDGE_URL.startswith(("ws://", "wss://")):
        errors.append(checks.Error("ROSBRIDGE_URL must start with ws:// or wss://", id="robot.E001"))
    if not settings.VIDEO_URL.startswith(("http://", "https://")):
        errors.append(checks.Error("VIDEO_URL must start with http:// or https://", id="robot.E002"))
    try:
        interface.reload()
        interface.topics(), interface.services(), interface.actions()
    except KeyError as exc:
        errors.append(checks.Error(f"ROBOT_NAME_OVERRIDES: {exc.args[0]}", id="robot.E003"))
    return errors

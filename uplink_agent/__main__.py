"""``python3 -m uplink_agent``: run the agent with its settings from the environment (see deploy/robot/)."""

import asyncio
import logging
import os
import signal
import sys

from .agent import Agent, Settings


def _float(name, default):
    value = os.environ.get(name, "")
    try:
        return float(value) if value else default
    except ValueError:
        raise SystemExit("%s must be a number, not %r" % (name, value))


def settings_from_env(env=None):
    env = os.environ if env is None else env
    credential = env.get("UPLINK_CREDENTIAL", "")
    path = env.get("UPLINK_CREDENTIAL_FILE", "")
    if path:
        with open(path) as f:
            credential = f.read().strip()
    return Settings(
        server_url=env.get("UPLINK_SERVER_URL", ""),
        credential=credential,
        rosbridge_url=env.get("UPLINK_ROSBRIDGE_URL", "ws://127.0.0.1:9090"),
        video_url=env.get("UPLINK_VIDEO_URL", "http://127.0.0.1:8080"),
        cmd_vel_topic=env.get("UPLINK_CMD_VEL_TOPIC", "/cmd_vel"),
        deadman_s=_float("UPLINK_DEADMAN_S", 0.4),
        ping_s=_float("UPLINK_PING_S", 2.0),
        silence_s=_float("UPLINK_SILENCE_S", 6.0),
        backoff_max_s=_float("UPLINK_BACKOFF_MAX_S", 10.0),
        proxy_url=env.get("UPLINK_PROXY", "") or env.get("HTTPS_PROXY", "") or env.get("https_proxy", ""),
        ca_file=env.get("UPLINK_CA_FILE", ""),
    )


def main():
    logging.basicConfig(level=os.environ.get("UPLINK_LOG_LEVEL", "INFO"),
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        settings = settings_from_env()
    except ValueError as exc:
        sys.exit("uplink agent: %s" % exc)
    loop = asyncio.get_event_loop()
    task = loop.create_task(Agent(settings).run())
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, task.cancel)
    try:
        loop.run_until_complete(task)
    except asyncio.CancelledError:
        pass
    loop.run_until_complete(asyncio.sleep(0.05))  # the last zero Twist and close frames leave
    loop.close()


if __name__ == "__main__":
    main()

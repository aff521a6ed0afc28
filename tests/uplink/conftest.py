from __future__ import annotations

import pytest

from tests.stack import free_port
from tests.uplink.support import Agent, make_credential


@pytest.fixture
async def endpoint(settings, transactional_db):
    """The uplink endpoint and its relays on the test's event loop, on free ports."""
    from robot import supervisor
    from robot.uplink import hosting

    settings.UPLINK = True
    settings.UPLINK_LISTEN = f"127.0.0.1:{free_port()}"
    settings.UPLINK_ROSBRIDGE_PORT = free_port()
    settings.UPLINK_VIDEO_PORT = free_port()
    settings.ROSBRIDGE_URL = f"ws://127.0.0.1:{settings.UPLINK_ROSBRIDGE_PORT}"
    settings.VIDEO_URL = f"http://127.0.0.1:{settings.UPLINK_VIDEO_PORT}"
    made = hosting.make_endpoint()
    await made.start()
    with supervisor.holding(made):
        yield made
    await made.stop()


@pytest.fixture
def credential(transactional_db):
    return make_credential()


@pytest.fixture
def agent_for(sim, endpoint):
    """Agents dialling ``endpoint`` on loopback for the simulator's rosbridge and camera."""
    started: list[Agent] = []

    def start(text: str, **extra: str) -> Agent:
        agent = Agent(server_url=f"ws://{endpoint.host}:{endpoint.port}/uplink/", credential=text,
                      rosbridge_url=sim.url, video_url=sim.video_url, **extra)
        started.append(agent.start())
        return agent

    yield start
    for agent in started:
        agent.__exit__()

"""The E-STOP's direct path to the link: signed requests only, only the E-STOP's own, from every
address at once, the answer of the link that acted."""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

import pytest
from django.test import override_settings

from robot.link import direct
from tests.stack import free_port


@contextlib.asynccontextmanager
async def serving(answers: list[dict[str, Any]], addresses: list[str]):
    seen: list[dict] = []

    async def execute(request: dict) -> dict:
        seen.append(request)
        return answers[min(len(seen), len(answers)) - 1]

    with override_settings(ROBOT_LINK_DIRECT_ADDRESSES=addresses):
        task = asyncio.ensure_future(direct.serve(execute))
        await asyncio.sleep(0.05)
        try:
            yield seen
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)


async def test_the_link_answers_the_estops_own_requests_and_refuses_everything_else():
    addresses = [f"127.0.0.1:{free_port()}"]
    async with serving([{"ok": True}], addresses) as seen:
        with override_settings(ROBOT_LINK_DIRECT_ADDRESSES=addresses):
            assert await direct.ask({"op": "estop", "request_id": "a"}, 1) == {"ok": True}
            assert await direct.ask({"op": "publish", "emergency": True, "request_id": "b"}, 1) == {"ok": True}
            refused = await direct.ask({"op": "publish", "stopping": True, "request_id": "c"}, 1)
            assert refused["error_code"] == "invalid"
        assert [r["request_id"] for r in seen] == ["a", "b"]

        host, port = addresses[0].split(":")
        reader, writer = await asyncio.open_connection(host, int(port))
        writer.write(b'{"op": "estop"}\n')  # not signed
        assert b"forbidden" in await reader.readline()
        writer.close()
        assert len(seen) == 2


async def test_a_web_process_takes_the_answer_of_the_active_link():
    taken = free_port()
    addresses = [f"127.0.0.1:{taken}", f"127.0.0.1:{free_port()}", f"127.0.0.1:{free_port()}"]
    blocker = await asyncio.start_server(lambda r, w: w.close(), "127.0.0.1", taken)  # something else has the first
    try:
        standby = {"ok": False, "error_code": "offline", "error": "This robot link lost its lease"}
        async with serving([standby], addresses[1:2]), serving([{"ok": True, "by": "active"}], addresses):
            with override_settings(ROBOT_LINK_DIRECT_ADDRESSES=addresses):
                assert await direct.ask({"op": "estop"}, 1) == {"ok": True, "by": "active"}
        async with serving([standby], addresses[1:2]):
            with override_settings(ROBOT_LINK_DIRECT_ADDRESSES=addresses):
                assert await direct.ask({"op": "estop"}, 1) == standby  # nobody active: the refusal says why
    finally:
        blocker.close()
    with override_settings(ROBOT_LINK_DIRECT_ADDRESSES=addresses[1:]), pytest.raises(direct.Unreachable):
        await direct.ask({"op": "estop"}, 1)  # nobody listens: the caller goes the usual way

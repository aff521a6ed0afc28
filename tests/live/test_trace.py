"""Stage timestamps of the probe key (robot.live.trace), the bench's view inside the server."""

import asyncio
import json

from robot.live import frames, trace
from robot.live.hub import Hub
from tests.helpers import async_wait_until
from tests.live.test_hub import FakeWriter


async def test_a_traced_update_is_written_as_one_line_of_ordered_stages(tmp_path, settings, monkeypatch):
    path = tmp_path / "trace.jsonl"
    settings.LIVE_TRACE_FILE = str(path)
    monkeypatch.setattr(trace, "enabled", True)
    monkeypatch.setattr(trace, "_out", None)
    hub = Hub(asyncio.get_running_loop())
    writers = [FakeWriter() for _ in range(3)]
    for writer in writers:
        hub.watch(hub.attach(lambda text: None, writer), [trace.KEY])
    t = 1000.25
    trace.begin(trace.KEY, t, {"header": {"stamp": {"secs": 1000, "nsecs": 200_000_000}}})
    trace.mark(t, "drain")
    hub.publish(trace.KEY, frames.update_fragment({"key": trace.KEY, "msg": {}, "t": t}), t)
    await async_wait_until(lambda: path.exists() and path.read_text(), timeout=2)
    trace._out.close()
    (record,) = [json.loads(line) for line in path.read_text().splitlines()]
    assert record["stamp"] == 1000.2 and record["recv"] == t and record["sockets"] == 3
    stages = [record[s] for s in ("loop", "drain", "hub", "flush", "written")]
    assert stages == sorted(stages)
    assert not trace._open

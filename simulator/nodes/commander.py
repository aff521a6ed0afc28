"""cyborg_commander: runs a robot mode as its sequence of events, pauses and emotion-system switches."""

from __future__ import annotations

import asyncio

from robot import interface as ri

from ..bus import Bus, SimNode

NODE = "/cyborg_commander"


class CommanderNode(SimNode):
    names = (NODE,)
    publishes = ()  # it announces on the controller's own topics (register_event, emotional_controller)

    def __init__(self, pause_s: float) -> None:
        self.pause_s = pause_s
        self.mode = ""  # the last robot_mode it ran
        self._queue: asyncio.Queue[str] = asyncio.Queue()

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("robot_mode", lambda m: self._queue.put_nowait(m["data"]))
        bus.spawn(self._run())

    async def _run(self) -> None:
        while True:
            name = await self._queue.get()
            try:
                mode = ri.Mode(name)
            except ValueError:
                self.bus.rosout(4, NODE, f"Unknown robot mode '{name}'")
                continue
            self.mode = mode.value
            self.bus.rosout(2, NODE, f"Robot mode: {mode.value}")
            for kind, value in ri.COMMANDER_SEQUENCES[mode]:
                if kind == "pause":
                    await self.bus.clock.sleep(self.pause_s)  # every pause in the sequences is this one
                elif kind == "event":
                    self.bus.announce("register_event", {"data": str(value)})
                elif kind == "emotion_system":
                    on = ri.EMOTION_SYSTEM_ON if value else ri.EMOTION_SYSTEM_OFF
                    self.bus.announce("emotional_controller", {"data": on})

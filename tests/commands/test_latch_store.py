"""The latch in the shared store: a second press keeps the first press's who and when, and the
steps of a stop are not written over a release (or a newer press) that came meanwhile."""

from __future__ import annotations

from robot.estop.latch import aengage, alatch, arecord_steps, arelease


async def test_a_second_press_keeps_the_first_press():
    first = await aengage(by="olga")
    again = await aengage(by="otto")
    assert again == first and (await alatch()).by == "olga"


async def test_the_steps_of_a_stop_never_overwrite_a_release_or_a_newer_press():
    pressed = await aengage(by="olga")
    await arelease(by="otto")
    steps = [{"step": "zero_velocity", "ok": True, "detail": "sent"}]
    kept = await arecord_steps(pressed, steps)
    assert not kept.latched and kept.released_by == "otto" and not (await alatch()).latched
    newer = await aengage(by="otto")
    assert (await arecord_steps(pressed, steps)).at == newer.at and (await alatch()).steps == []
    assert (await arecord_steps(newer, steps)).steps == steps

"""The state watch on a store filled by hand: what counts after the link (re)connected."""

from __future__ import annotations

from robot.commands.statewatch import StateWatch, leaf_from_smach
from robot.live.groups import STATUS_KEY
from robot.live.state import StateStore, get_store


def smach(t: float, path: str, *active: str) -> dict:
    return {"t": t, "msg": {"path": path, "active_states": list(active)}}


def change(t: float, event: str, old: str, new: str) -> dict:
    return {"t": t, "msg": {"event": event, "from_system_state": old, "to_system_state": new}}


async def filled(*, since: float | None, changes=(), statuses=()) -> StateStore:
    store = get_store()
    if since is not None:
        await store.aput(STATUS_KEY, {"connected": True, "since": since})
    for entry in changes:
        await store.aput("state_change", entry)
        await store.aappend_recent("state_change", entry, 20)
    for entry in statuses:
        await store.aappend_recent("smach_status", entry, 8)
    return store


def test_the_leaf_is_found_through_nested_containers():
    assert leaf_from_smach([
        smach(1, "/SM_ROOT", "behaviour"), smach(1, "/SM_ROOT/behaviour", "navigation"),
        smach(1, "/SM_ROOT/behaviour/navigation", "wandering_emotional"),
    ]) == "wandering_emotional"
    assert leaf_from_smach([smach(1, "/SM_ROOT/behaviour", "idle"), smach(2, "/SM_ROOT", "demo")]) == "demo"
    # A container whose own status has not come yet: no leaf, rather than the container's name.
    assert leaf_from_smach([smach(1, "/SM_ROOT", "behaviour")]) == ""
    assert leaf_from_smach([]) == ""


async def test_changes_from_before_the_connect_do_not_count():
    store = await filled(since=100.0, changes=[change(50.0, "aborted", "demo", "suspension")])
    assert await StateWatch(store).start() == ""
    store = await filled(since=100.0, changes=[change(50.0, "aborted", "demo", "suspension")],
                         statuses=[smach(40.0, "/SM_ROOT", "demo"), smach(101.0, "/SM_ROOT", "startup")])
    assert await StateWatch(store).start() == "startup"
    store = await filled(since=100.0, changes=[change(102.0, "succeeded", "startup", "suspension")],
                         statuses=[smach(101.0, "/SM_ROOT", "startup")])
    assert await StateWatch(store).start() == "suspension"


async def test_only_changes_after_the_start_are_new():
    store = await filled(since=10.0, changes=[change(20.0, "demo_start", "suspension", "demo")])
    watch = StateWatch(store)
    assert await watch.start() == "demo"
    assert await watch.wait_for(lambda c: True, 0) is None
    later = change(30.0, "aborted", "demo", "suspension")
    await store.aappend_recent("state_change", later, 20)
    assert await watch.wait_for(lambda c: True, 0) == later["msg"]
    assert watch.state == "suspension"

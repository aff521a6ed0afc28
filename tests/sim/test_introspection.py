"""The simulator's SMACH introspection, diagnostics, bumpers and sonar, consistent with its world."""

from __future__ import annotations

import math

from robot import interface as ri
from tests.sim.support import wait_until
from tests.sim.test_robot import call, drive, pub, set_pose, state, sub


def components(msg: dict) -> dict[str, tuple[int, str]]:
    return {s["name"]: (s["level"], s["message"]) for s in msg["status"]}


def test_the_introspection_follows_the_state_machine_through_its_containers(sim, ros):
    structure, status = sub(ros, "smach_structure"), sub(ros, "smach_status")
    paths = structure.wait(lambda items: {m["path"] for m in items} >= {
        "/SM_ROOT", "/SM_ROOT/behaviour", "/SM_ROOT/behaviour/navigation"} and items, timeout=10)
    root = next(m for m in paths if m["path"] == "/SM_ROOT")
    assert ("suspension", "demo_start", "demo") in zip(root["outcomes_from"], root["internal_outcomes"],
                                                         root["outcomes_to"], strict=True)
    wait_until(lambda: state(sim)["smach_state"] == "suspension", what="startup done")
    pub(ros, "register_event", {"data": "behaviour_start"})
    status.wait_for(lambda m: m["path"] == "/SM_ROOT/behaviour" and m["active_states"] == ["idle"])
    pub(ros, "register_event", {"data": "navigation_emotional"})
    status.wait_for(lambda m: m["path"] == "/SM_ROOT/behaviour/navigation" and m["active_states"])
    pub(ros, "register_event", {"data": "aborted"})  # the navigation leaf's outcome: back to idle
    status.wait_for(lambda m: m["path"] == "/SM_ROOT/behaviour" and m["active_states"] == ["idle"]
                    and status.items.index(m) > len(status.items) - 4)
    wait_until(lambda: state(sim)["smach_state"] == "idle")


def test_diagnostics_report_each_part_and_follow_the_motors(sim, ros):
    diagnostics = sub(ros, "diagnostics")
    first = diagnostics.wait(lambda items: items and items[-1], timeout=5)
    assert set(components(first)) == {"RosAria: Battery", "RosAria: Motors", "RosAria: Bumpers",
                                      "Laser: front scanner", "RosAria: Sonar"}
    assert components(first)["RosAria: Motors"] == (ri.DIAGNOSTIC_OK, "Motors enabled")
    call(ros, "disable_motors")
    diagnostics.wait_for(lambda m: components(m)["RosAria: Motors"] == (ri.DIAGNOSTIC_WARN, "Motors disabled"))
    call(ros, "enable_motors")
    diagnostics.wait_for(lambda m: components(m)["RosAria: Motors"][0] == ri.DIAGNOSTIC_OK
                         and diagnostics.items.index(m) > 0)


def test_a_bump_shows_on_the_bumpers_and_in_the_diagnostics(sim, ros):
    diagnostics, bumpers = sub(ros, "diagnostics"), sub(ros, "bumper_state")
    set_pose(ros, sim, 5.0, -6.2, -math.pi / 2)  # 0.65 m north of the south wall, facing it
    drive(ros, 1.0, 0.0, 1.5)
    bumpers.wait_for(lambda m: any(m["front_bumpers"]) and not any(m["rear_bumpers"]))
    diagnostics.wait_for(lambda m: components(m)["RosAria: Bumpers"] == (ri.DIAGNOSTIC_WARN, "Front bumper pressed"))
    diagnostics.wait_for(lambda m: components(m)["Laser: front scanner"][0] == ri.DIAGNOSTIC_WARN)
    bumpers.wait_for(lambda m: not any(m["front_bumpers"]) and bumpers.items.index(m) > 0, timeout=5)


def test_sonar_echoes_come_from_the_maps_walls(sim, ros):
    world = sim.robot.world
    set_pose(ros, sim, 5.0, -6.2, -math.pi / 2)
    sonar = sub(ros, "sonar")
    msg = sonar.wait(lambda items: items and items[-1])
    assert msg["header"]["frame_id"] == "sonar"
    x0, y0, yaw = 5.0, -6.2, -math.pi / 2
    sx, sy = x0 + 0.1 * math.cos(yaw), y0 + 0.1 * math.sin(yaw)  # the ring, 0.1 m ahead on /tf_static
    hits = 0
    for p in msg["points"]:
        r = math.hypot(p["x"], p["y"])
        if r >= 4.99:
            continue  # nothing within range
        a = yaw + math.atan2(p["y"], p["x"])
        x, y = sx + r * math.cos(a), sy + r * math.sin(a)
        # The echo is the first sample inside a wall and the one before it is free (1 mm: float32 points).
        step, eps = world.resolution, 0.001
        assert world.occupied(x + eps * math.cos(a), y + eps * math.sin(a)), (x, y)
        back = r - step - eps
        assert not world.occupied(sx + back * math.cos(a), sy + back * math.sin(a)), (x, y)
        hits += 1
    assert hits >= 3

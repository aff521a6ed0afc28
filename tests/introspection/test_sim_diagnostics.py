"""The simulator's diagnostics follow its world: battery, motors, bumpers, laser, sonar."""

from __future__ import annotations

from dataclasses import replace

from simulator.nodes import diagnostics as simdiag

CALM = simdiag.Reading(soc=0.8, voltage=25.4, recharge_state=0, motors=True, v=0.0, w=0.0, cmd_v=0.0, cmd_w=0.0,
                       front_bumped=False, rear_bumped=False, laser_nearest_m=2.0, laser_max_m=20.0,
                       sonar_nearest_m=1.5)


def levels(reading):
    return {s["name"]: (s["level"], s["message"]) for s in simdiag.statuses(reading)}


def test_a_calm_robot_reports_every_part_ok():
    assert {level for level, _ in levels(CALM).values()} == {0}
    assert set(levels(CALM)) == {"RosAria: Battery", "RosAria: Motors", "RosAria: Bumpers", "Laser: front scanner",
                                 "RosAria: Sonar"}


def test_parts_warn_and_fail_as_the_world_says():
    assert levels(replace(CALM, soc=0.1))["RosAria: Battery"] == (1, "Battery low: 10%")
    assert levels(replace(CALM, soc=0.01))["RosAria: Battery"][0] == 2
    assert levels(replace(CALM, motors=False))["RosAria: Motors"] == (1, "Motors disabled")
    stalled = replace(CALM, cmd_v=0.3, v=0.0, front_bumped=True)
    assert levels(stalled)["RosAria: Motors"] == (2, "Stalled against an obstacle")
    assert levels(stalled)["RosAria: Bumpers"] == (1, "Front bumper pressed")
    assert levels(replace(CALM, laser_nearest_m=0.1))["Laser: front scanner"][0] == 1


def test_the_node_publishes_each_second_and_at_once_when_a_level_moves():
    node = simdiag.DiagnosticsNode(None)
    assert node.poll(CALM, 0.0) is not None
    assert node.poll(CALM, 0.5) is None
    off = replace(CALM, motors=False)
    assert node.poll(off, 0.6) is not None
    assert node.poll(off, 1.0) is None
    sent = node.poll(off, 1.7)
    assert sent is not None
    assert [s["level"] for s in sent["status"] if s["name"] == "RosAria: Motors"] == [1]

"""The state machine as a graph: containers from their structure, the active states from their
status or, without introspection, from state_change; the events that leave the active state."""

from __future__ import annotations

import re

import pytest

from robot.introspection import smach
from simulator.nodes.controller import StateMachine


def sim_containers() -> dict[str, smach.Container]:
    return {path: smach.Container(path, tuple(children), tuple(edges), tuple(outcomes))
            for path, children, edges, outcomes in StateMachine.smach_structure()}


def sim_statuses(state: str, t: float = 100.0) -> dict[str, smach.Status]:
    machine = StateMachine(lambda *a: None, initial=state)
    return {path: smach.Status(tuple(active), tuple(initial), t) for path, initial, active in machine.smach_status()}


def structure_message(**fields):
    msg = {"header": {}, "path": "/SM", "children": ["a", "b"], "internal_outcomes": ["go", "done"],
           "outcomes_from": ["a", "b"], "outcomes_to": ["b", "finished"], "container_outcomes": ["finished"]}
    return {**msg, **fields}


def test_it_reads_a_container_structure_message():
    c = smach.container_from_message(structure_message())
    assert c == smach.Container("/SM", ("a", "b"), (("a", "go", "b"), ("b", "done", "finished")), ("finished",))


@pytest.mark.parametrize("fields, error", [
    ({"path": "SM"}, "absolute path"),
    ({"path": None}, "absolute path"),
    ({"children": "a"}, "children"),
    ({"outcomes_to": ["b"]}, "differ in length"),
    ({"internal_outcomes": [1, 2]}, "internal_outcomes"),
])
def test_it_refuses_a_structure_that_is_no_container(fields, error):
    with pytest.raises(ValueError, match=error):
        smach.container_from_message(structure_message(**fields))


def test_the_graph_has_every_state_outcome_and_edge_of_the_simulators_machine():
    containers = sim_containers()
    graph = smach.graph_view(containers)
    paths = {n["path"]: n for n in graph["nodes"]}
    assert {"/SM_ROOT/suspension", "/SM_ROOT/behaviour/idle",
            "/SM_ROOT/behaviour/navigation/wandering_emotional"} <= set(paths)
    assert paths["/SM_ROOT/behaviour:succeeded"]["kind"] == "outcome"
    assert "/SM_ROOT/behaviour" not in paths  # a container is a box (cluster), not a node
    assert len(graph["edges"]) == sum(len(c.edges) for c in containers.values())
    assert set(graph["clusters"].values()) == set(containers)
    # Every node and edge id the page looks up is in the DOT text, once.
    for item in graph["nodes"] + graph["edges"]:
        assert len(re.findall(rf'id="{item["id"]}"', graph["dot"])) == 1


def test_edges_into_and_out_of_a_container_attach_to_its_box():
    graph = smach.graph_view(sim_containers())
    ids = {n["path"]: n["id"] for n in graph["nodes"]}
    clusters = {p: c for c, p in graph["clusters"].items()}
    line = _edge_line(graph, "/SM_ROOT/suspension", "behaviour_start")
    assert line.startswith(f'{ids["/SM_ROOT/suspension"]} -> {ids["/SM_ROOT/behaviour/idle"]} ')
    assert f"lhead={clusters['/SM_ROOT/behaviour']}" in line
    # A container's outcome leaves from its outcome node.
    line = _edge_line(graph, "/SM_ROOT/behaviour", "succeeded")
    assert line.startswith(f'{ids["/SM_ROOT/behaviour:succeeded"]} -> {ids["/SM_ROOT/suspension"]} ')


def _edge_line(graph, frm: str, event: str) -> str:
    edge = next(e for e in graph["edges"] if e["from"] == frm and e["event"] == event)
    return next(line for line in graph["dot"].splitlines() if f'id="{edge["id"]}"' in line)


def test_the_version_follows_the_structure_only():
    containers = sim_containers()
    same = smach.graph_view(dict(reversed(list(containers.items()))))
    assert smach.graph_view(containers)["version"] == same["version"]
    root = containers["/SM_ROOT"]
    containers["/SM_ROOT"] = smach.Container(root.path, root.children, root.edges[1:], root.outcomes)
    assert smach.graph_view(containers)["version"] != same["version"]


def test_names_are_quoted_in_the_dot_text():
    c = smach.Container("/SM", ('say "hi"',), (('say "hi"', "done\\", "end"),), ("end",))
    dot = smach.graph_view({"/SM": c})["dot"]
    assert 'label="say \\"hi\\""' in dot and 'label="done\\\\"' in dot


def test_the_active_states_come_from_each_containers_status():
    view = smach.active_view(sim_containers(), sim_statuses("navigation_go_to_emotional"), "", now=101, fresh_s=5)
    assert view["source"] == "introspection"
    assert view["active"] == ["/SM_ROOT/behaviour", "/SM_ROOT/behaviour/navigation",
                              "/SM_ROOT/behaviour/navigation/navigation_go_to_emotional"]
    assert view["leaves"] == ["/SM_ROOT/behaviour/navigation/navigation_go_to_emotional"]
    assert {t["event"]: t["to"] for t in view["transitions"]} == {
        "succeeded": "/SM_ROOT/behaviour/navigation:succeeded", "aborted": "/SM_ROOT/behaviour/navigation:aborted",
        "power_low": "/SM_ROOT/behaviour/navigation:power_low"}


def test_a_container_left_behind_does_not_count():
    statuses = {**sim_statuses("sleeping"), **sim_statuses("suspension", t=101)}
    view = smach.active_view(sim_containers(), statuses, "", now=101, fresh_s=5)
    assert view["active"] == ["/SM_ROOT/suspension"]
    assert {t["event"] for t in view["transitions"]} == {
        "behaviour_start", "restart", "demo_start", "manual_start", "aborted", "succeeded"}


def test_without_fresh_introspection_state_change_names_the_state():
    containers = sim_containers()
    stale = sim_statuses("suspension", t=0)
    view = smach.active_view(containers, stale, "sleeping", now=100, fresh_s=5)
    assert view["source"] == "state_change"
    assert view["active"] == ["/SM_ROOT/behaviour", "/SM_ROOT/behaviour/sleeping"]
    assert {t["event"] for t in view["transitions"]} == {"preempted", "cyborg_wake_up"}
    assert smach.active_view(containers, {}, "", now=100, fresh_s=5) == {
        "source": "", "active": [], "leaves": [], "transitions": []}
    assert smach.active_view(containers, {}, "no_such_state", now=100, fresh_s=5)["active"] == []


def test_every_state_of_the_simulator_offers_the_events_its_table_accepts():
    from simulator.nodes.controller import TABLE

    containers = sim_containers()
    for state, table in TABLE.items():
        view = smach.active_view(containers, sim_statuses(state), "", now=100, fresh_s=5)
        assert {t["event"] for t in view["transitions"]} == set(table), state

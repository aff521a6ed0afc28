"""Diagnostics by component: merged across arrays, worst level, changes that matter."""

from __future__ import annotations

from robot.introspection import diagnostics as diag


def array(*statuses):
    return {"header": {}, "status": list(statuses)}


def status(name, level=0, message="ok", **values):
    return {"level": level, "name": name, "message": message, "hardware_id": "hw",
            "values": [{"key": k, "value": v} for k, v in values.items()]}


def test_components_reported_apart_are_kept_apart_and_the_newest_wins():
    known = diag.merge({}, diag.components_from_message(array(status("battery", voltage="25.1")), 1.0), now=1.0)
    known = diag.merge(known, diag.components_from_message(array(status("laser", 1, "dirty window")), 2.0), now=2.0)
    known = diag.merge(known, diag.components_from_message(array(status("battery", 2, "empty")), 3.0), now=3.0)
    view = diag.summary(known)
    assert [(c["name"], c["level_name"], c["message"], c["t"]) for c in view["components"]] == [
        ("battery", "ERROR", "empty", 3.0), ("laser", "WARN", "dirty window", 2.0)]
    assert view["worst"] == 2 and view["worst_name"] == "ERROR"


def test_values_and_hardware_id_are_shown():
    (c,) = diag.components_from_message(array(status("battery", voltage="25.1", soc="80 %")), 1.0)
    assert c.as_dict()["values"] == [["voltage", "25.1"], ["soc", "80 %"]]
    assert c.hardware_id == "hw"


def test_nameless_or_odd_entries_are_skipped_or_marked():
    parts = diag.components_from_message(array({"level": 0, "name": ""}, "junk", status("x", level="high")), 1.0)
    assert [(c.name, c.level_name) for c in parts] == [("x", "STALE")]
    assert diag.components_from_message({"status": None}, 1.0) == []


def test_a_component_unheard_of_for_long_is_forgotten():
    known = diag.merge({}, diag.components_from_message(array(status("old")), 0.0), now=0.0)
    later = diag.merge(known, diag.components_from_message(array(status("new")), 1.0), now=diag.FORGET_AFTER_S + 1)
    assert set(later) == {"new"}


def test_only_a_level_message_or_component_change_counts_as_a_change():
    a = diag.merge({}, diag.components_from_message(array(status("m", voltage="1")), 1.0), now=1.0)
    b = diag.merge(a, diag.components_from_message(array(status("m", voltage="2")), 2.0), now=2.0)
    assert not diag.changed_levels(a, b)
    c = diag.merge(b, diag.components_from_message(array(status("m", 1, "hot")), 3.0), now=3.0)
    assert diag.changed_levels(b, c)
    d = diag.merge(c, diag.components_from_message(array(status("n")), 4.0), now=4.0)
    assert diag.changed_levels(c, d)


def test_with_nothing_reported_all_is_ok():
    assert diag.summary({}) == {"components": [], "worst": 0, "worst_name": "OK"}

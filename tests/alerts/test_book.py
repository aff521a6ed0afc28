"""The alert book and its rules: plain data in, the change made out."""

from robot.alerts import rules
from robot.alerts.book import AlertBook
from robot.introspection.diagnostics import Component


def component(name: str, level: int, t: float, message: str = "") -> Component:
    return Component(name, level, message, "hw", (), t)


def test_it_raises_a_condition_once_and_keeps_its_start_while_it_holds():
    book = AlertBook()
    first = book.apply(rules.battery({"data": 0.15}, low_percent=20), now=100.0)
    assert first.what == "raised" and first.record.started_at == 100.0 and first.record.severity == "warning"
    assert book.apply(rules.battery({"data": 0.15}, low_percent=20), now=101.0) is None
    worse = book.apply(rules.battery({"data": 0.05}, low_percent=20), now=102.0)
    assert worse.what == "updated" and worse.record.severity == "critical" and worse.record.started_at == 100.0
    ended = book.apply(rules.battery({"data": 0.5}, low_percent=20), now=103.0)
    assert ended.what == "ended" and ended.record.ended_at == 103.0 and ended.record.id == first.record.id
    assert book.snapshot() == {"alerts": []}


def test_it_counts_repeated_log_lines_from_one_node_and_ends_them_after_a_quiet_spell():
    book = AlertBook(event_quiet_s=60)
    line = {"level": 16, "name": "/nav", "msg": "planner died", "header": {"stamp": {"secs": 50, "nsecs": 0}}}
    raised = book.apply(rules.log_line(line, 51.0), now=51.0)
    assert raised.record.severity == "critical" and raised.record.started_at == 50.0
    assert raised.record.text == "FATAL from /nav: planner died"
    again = book.apply(rules.log_line({**line, "level": 8, "msg": "again"}, 55.0), now=55.0)
    assert again.record.count == 2 and again.record.text == "ERROR from /nav: again"
    assert rules.log_line({**line, "level": 4}, 56.0) is None  # a WARN line is no alert
    assert book.expire(100.0) == []
    assert [c.what for c in book.expire(116.0)] == ["ended"]


def test_an_acknowledged_event_ends_and_an_acknowledged_condition_stays_until_it_clears():
    book = AlertBook()
    event = book.apply(rules.bumper(["front"], 10.0), now=10.0).record
    condition = book.apply(rules.estop(latched=True, by="olga", at=9.0), now=10.0).record
    assert condition.text == "E-STOP engaged by olga" and condition.started_at == 9.0
    acked = book.ack(event.id, "olga", 11.0)
    assert acked.what == "ended" and acked.record.acked_by == "olga"
    still = book.ack(condition.id, "olga", 12.0)
    assert still.what == "acked" and [a["id"] for a in book.snapshot()["alerts"]] == [condition.id]
    assert book.ack("no-such-id", "olga", 13.0) is None
    assert book.apply(rules.estop(latched=False, by="", at=0), now=14.0).what == "ended"


def test_diagnostics_keep_the_level_current_a_silent_component_turns_stale_and_recovery_ends_it():
    book = AlertBook()
    warn = rules.diagnostics([component("Motors", 1, 100.0, "hot")], now=101.0, stale_after_s=10)
    raised = book.apply(warn[0], now=101.0)
    assert raised.record.text == "Motors: WARN · hot"
    stale = rules.diagnostics([component("Motors", 1, 100.0, "hot")], now=111.0, stale_after_s=10)
    updated = book.apply(stale[0], now=111.0)
    assert updated.what == "updated" and updated.record.text.startswith("Motors: STALE")
    assert updated.record.started_at == 101.0
    ok = rules.diagnostics([component("Motors", 0, 112.0)], now=112.0, stale_after_s=10)
    assert ok == []
    assert [c.record.key for c in book.end_missing("diag:", set(), 112.0)] == ["diag:Motors"]


def test_offline_waits_out_a_reconnects_blink_and_not_responding_needs_a_connection():
    quick = {s.key: s.on for s in rules.link(connected=False, offline_for=1.0, responding=True, grace_s=2)}
    assert quick == {"offline": False, "not_responding": False}
    down = {s.key: s.on for s in rules.link(connected=False, offline_for=2.5, responding=False, grace_s=2)}
    assert down == {"offline": True, "not_responding": False}
    hung = {s.key: s.on for s in rules.link(connected=True, offline_for=0, responding=False, grace_s=2)}
    assert hung == {"offline": False, "not_responding": True}

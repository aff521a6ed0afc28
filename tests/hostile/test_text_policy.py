"""The one text policy: what people send is refused with the field and reason and never reaches
the robot; what the robot (or an old row) holds is rendered with U+FFFD, never a 500."""

from __future__ import annotations

import json

import pytest
from django.db import connection

from cyborg_site.text import TextRejected, clean_text, scrub, scrub_json, text_problem
from robot.commands.audit import audit_record
from robot.models import AuditEntry
from tests.commands.support import only_the_marker_arrived, sent_to_robot

pytestmark = pytest.mark.postgres  # text the engine refuses (NUL, lone surrogates) and rows an older engine kept

LONE = "\ud800"


def test_it_accepts_ordinary_text_newlines_tabs_and_emoji():
    assert clean_text("  hei på deg\n\tsmile 😀 ", field="text", limit=50, multiline=True) == "hei på deg\n\tsmile 😀"


@pytest.mark.parametrize(("value", "reason"), [
    (f"a{LONE}b", "lone UTF-16 surrogate"),
    ("a\x00b", "control character (U+0000)"),
    ("a\x1bb", "control character (U+001B)"),
    ("a\x85b", "control character (U+0085)"),
    ("abc\u202eevil", "text-direction control character (U+202E RIGHT-TO-LEFT OVERRIDE)"),
    ("x" * 11, "at most 10 characters (got 11)"),
])
def test_it_refuses_text_against_the_policy_naming_the_reason(value, reason):
    with pytest.raises(TextRejected) as caught:
        clean_text(value, field="text", limit=10)
    assert caught.value.field == "text" and reason in caught.value.reason


# Invisible or unassigned: they would pass into the robot's speech unseen in the field.
INVISIBLE = [
    ("\u2028", "line separator (U+2028 LINE SEPARATOR)"),
    ("\u2029", "paragraph separator (U+2029 PARAGRAPH SEPARATOR)"),
    ("\u200d", "invisible formatting character (U+200D ZERO WIDTH JOINER)"),
    ("\u200b", "invisible formatting character (U+200B ZERO WIDTH SPACE)"),
    ("\ufeff", "invisible formatting character (U+FEFF ZERO WIDTH NO-BREAK SPACE)"),
    ("\U000e0067", "invisible formatting character (U+E0067 TAG LATIN SMALL LETTER G)"),
    ("\U000e007f", "invisible formatting character (U+E007F CANCEL TAG)"),
    ("\uffff", "unassigned code point or noncharacter (U+FFFF)"),
    ("\ufffe", "unassigned code point or noncharacter (U+FFFE)"),
    ("\U0010ffff", "unassigned code point or noncharacter (U+10FFFF)"),
    ("\ue000", "private-use character (U+E000)"),
]


@pytest.mark.parametrize(("char", "reason"), INVISIBLE)
def test_it_refuses_invisible_and_unassigned_characters_naming_them(char, reason):
    problem = text_problem(f"hello{char}there", limit=50, multiline=True)
    assert problem is not None and reason in problem
    assert problem.endswith("only letters, marks, digits, punctuation, symbols (emoji too), spaces, newlines and "
                            "tabs are accepted.")


def test_it_accepts_emoji_with_skin_tones_variation_selectors_and_flags_but_not_joined_ones():
    assert text_problem("👍🏽 ❤️ 🇳🇴 1️⃣ naïve\u00a0text", limit=50) is None
    assert "U+200D" in text_problem("👩\u200d🚀", limit=50)
    assert "U+E0067" in text_problem("🏴\U000e0067\U000e0062\U000e0065\U000e006e\U000e0067\U000e007f", limit=50)


@pytest.mark.django_db
def test_it_refuses_invisible_characters_in_speech_through_the_api_and_never_sends_them(operator_api, robot):
    for char, reason in INVISIBLE:
        for ascii_only in (True, False):  # as JSON escapes and as UTF-8
            body = json.dumps({"text": f"hello{char}there"}, ensure_ascii=ascii_only)
            res = operator_api.post("/api/robot/speech/", body, content_type="application/json")
            assert res.status_code == 400, (char, res.content)
            data = res.json()
            assert (data["code"], data["field"]) == ("invalid", "text"), data
            assert data["detail"].startswith("text: contains ") and reason in data["detail"], data
    assert only_the_marker_arrived(robot, operator_api), sent_to_robot(robot)


def test_it_allows_newlines_only_in_multiline_fields():
    assert text_problem("a\nb", limit=10) is not None
    assert text_problem("a\nb", limit=10, multiline=True) is None


def test_it_scrubs_lone_surrogates_everywhere_in_json():
    assert scrub(f"ok{LONE}") == "ok\ufffd"
    assert scrub_json({f"k{LONE}": [1, f"v{LONE}", {"n": None}]}) == {"k\ufffd": [1, "v\ufffd", {"n": None}]}


BAD_BODIES = [
    ("/api/robot/speech/", '{"text": "\\ud800"}', "text", "surrogate"),
    ("/api/robot/speech/", '{"text": "hi\\u0000there"}', "text", "U+0000"),
    ("/api/robot/speech/", '{"text": "abc\\u202eevil"}', "text", "U+202E"),
    ("/api/robot/event/", '{"event": "\\udfff"}', "event", "surrogate"),
    ("/api/robot/emotion/", '{"emotion": "happy\\u0007"}', "emotion", "U+0007"),
    ("/api/robot/speech/", '{"text\\ud800": "x"}', "text\ufffd", "field name"),
    ("/api/navigation/goal/", '{"x": 1, "y": 2, "note": {"deep": "\\ud800"}}', "note.deep", "surrogate"),
    ("/api/locations/", '{"name": "dock", "x": 1, "y": 1, "description": "a\\u0000"}', "description", "U+0000"),
]


@pytest.mark.django_db
def test_it_refuses_bad_text_with_the_field_and_never_sends_it(operator_api, robot):
    for path, body, field, reason in BAD_BODIES:
        res = operator_api.post(path, body, content_type="application/json")
        assert res.status_code == 400, (path, body, res.content)
        data = res.json()
        assert (data["code"], data["field"]) == ("invalid", field), data
        assert reason in data["detail"], data
    assert only_the_marker_arrived(robot, operator_api), sent_to_robot(robot)


@pytest.mark.django_db
def test_it_applies_the_policy_to_form_bodies_too(operator_api):
    res = operator_api.post("/api/locations/", {"name": "dock", "x": "1", "y": "1", "description": "a\x1bb"})
    assert res.status_code == 400 and res.json()["field"] == "description", res.content
    res = operator_api.post("/api/robot/speech/", {"text": "hi\x07"}, format="multipart")
    assert res.status_code == 400 and res.json()["field"] == "text", res.content


def test_it_refuses_control_characters_over_the_live_command_path():
    from robot.commands.pipeline import InvalidCommand
    from robot.commands.validation import clean_speech

    with pytest.raises(InvalidCommand) as caught:
        clean_speech("a\x00b")
    assert caught.value.field == "text"
    assert clean_speech("two\nlines") == "two\nlines"


@pytest.mark.django_db
def test_it_stores_and_renders_robot_text_with_lone_surrogates(operator, viewer_api, client):
    # A refusal text from the robot goes into the audit log as it came, on either database.
    audit_record(user=operator, source="api", action="speech", params={"text": f"bad{LONE}"}, ok=False,
                 outcome=f"robot said {LONE}")
    if connection.vendor == "sqlite":  # a row written before the policy (PostgreSQL never took one)
        AuditEntry.objects.create(user=operator, username="otto", source="api", action="old",
                                  params={"text": f"old{LONE}"}, ok=False, outcome="old")
    api = viewer_api.get("/api/audit/")
    assert api.status_code == 200
    assert {"text": "bad\ufffd"} in [row["params"] for row in api.json()["results"]]
    client.force_login(operator)
    page = client.get("/activity/")
    assert page.status_code == 200
    assert "robot said \ufffd" in page.content.decode()

"""A short schemathesis run against the live schema of a real server (simulator + Daphne),
as an operator and as a viewer, and the hostile values the schema cannot express (tests/fuzzing.py):
no server errors, no responses the schema does not describe, no writes by the viewer, no hostile
value taken. ``bench/fuzz.py`` runs the same, longer."""

from __future__ import annotations

import json
import urllib.error
import urllib.request

import pytest
from django.conf import settings

from tests.fuzzing import api_token, fuzz_api
from tests.stack import PASSWORD, Stack

# The live stack is the embedded wiring in both passes of the suite: run it once.
pytestmark = pytest.mark.skipif(not settings.EMBEDDED, reason="the fuzzed stack is the same in both passes")


def post(url: str, body: bytes, content_type: str, token: str) -> tuple[int, str, bytes]:
    request = urllib.request.Request(url, data=body, method="POST",
                                     headers={"Authorization": f"Token {token}", "Content-Type": content_type})
    try:
        with urllib.request.urlopen(request, timeout=10) as res:
            return res.status, res.headers.get("Content-Type", ""), res.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.headers.get("Content-Type", ""), exc.read()


@pytest.mark.timeout(240)
def test_fuzzing_the_live_api_finds_no_server_error_schema_violation_or_viewer_write():
    with Stack() as stack:
        stack.wait_robot_online()
        # What the HTTP server itself used to refuse with an empty 400: a multipart body with no parts.
        status, content_type, body = post(f"{stack.url}/api/robot/speech/", b"--b--\r\n",
                                          "multipart/form-data; boundary=b", api_token(stack.url, "otto", PASSWORD))
        assert (status, content_type) == (400, "application/json"), body
        assert json.loads(body)["field"] == "text"
        report = fuzz_api(stack.url, operator=("otto", PASSWORD), viewer=("vera", PASSWORD), max_examples=1)
    assert report.requests > 60, report.lines()  # every operation, more than once
    assert report.hostile_requests > 100, report.lines()  # non-finite numbers and invisible characters too
    assert report.clean, "\n".join(report.problems[:20])


def test_the_hostile_bodies_put_each_non_finite_literal_and_invisible_character_in_each_leaf():
    from tests.fuzzing import EDGE_CHARACTERS, NON_FINITE, hostile_json

    bodies = list(hostile_json({"text": "hi", "pose": {"x": 1.5}}))
    assert '{"text": NaN, "pose": {"x": 1.5}}' in bodies and '{"text": "hi", "pose": {"x": 1e400}}' in bodies
    assert '{"text": "hi\u200dx", "pose": {"x": 1.5}}' in bodies
    assert len(bodies) == 2 * len(NON_FINITE) + len(EDGE_CHARACTERS)
    assert list(hostile_json({})) == list(NON_FINITE)  # no leaves: the whole body

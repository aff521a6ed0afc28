"""Fuzz the live API from its own OpenAPI schema (schemathesis), once as an operator and once
as a viewer, and count what matters: requests, server errors, responses the schema does not
describe, and writes a viewer got through. Used by the suite (short run) and bench/fuzz.py.

Beside the schema's own strategies, the operator's first schema-valid cases of each operation are
sent again with hostile values the schema cannot express, as raw JSON: each leaf of the body (and
each query parameter) in turn a number Python's json reads as infinite or NaN (``1e400``, ``NaN``,
``-Infinity``, ...), each string with a character the text policy refuses (line and paragraph
separators, a zero-width joiner, the BOM, noncharacters, a tag character, private use). Each must
be refused, never answered with a 500 or taken by a write (``hostile_accepted``).
"""

from __future__ import annotations

import json
import time
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import requests
import schemathesis
from hypothesis import HealthCheck, Phase, given
from hypothesis import settings as hypothesis_settings
from hypothesis.errors import Unsatisfiable
from schemathesis import GenerationMode
from schemathesis.core.failures import Failure, FailureGroup
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    response_schema_conformance,
    status_code_conformance,
)

SCHEMA_CHECKS = [status_code_conformance, content_type_conformance, response_schema_conformance]
UNSAFE = {"POST", "PUT", "PATCH", "DELETE"}
# Requests a viewer may make that change nothing of the robot's or anyone else's: a token of
# their own, their own map overlay choices and theme, which alerts reach them and in which browsers, a
# ticket for a ROS tool of their own (through the front door it has their role: a viewer's only watches).
NOT_A_WRITE = {("POST", "/api/auth/token/"), ("POST", "/api/frontdoor/ticket/"), ("PATCH", "/api/me/map-overlays/"),
               ("PATCH", "/api/me/theme/"),
               ("PATCH", "/api/me/alert-delivery/"), ("POST", "/api/me/push-subscriptions/"),
               ("DELETE", "/api/me/push-subscriptions/")}
# What those leave in the audit log (a token made for its owner, an expired one replaced).
NOT_A_WRITE_ACTIONS = {"token.created", "token.deleted"}
# JSON number literals Python's json parses (as inf, -inf and nan), and text nobody sees.
NON_FINITE = ("1e400", "-1e400", "NaN", "Infinity", "-Infinity")
EDGE_CHARACTERS = ("\u2028", "\u2029", "\u200d", "\ufeff", "\ufffe", "\uffff", "\U000e0041", "\ue000")
HOSTILE_CASES = 2  # of each operation's schema-valid cases, sent again with every hostile value
_HOLE = "\x00fuzz-hole\x00"


@dataclass
class FuzzReport:
    requests: int = 0
    server_errors: int = 0
    schema_violations: int = 0
    viewer_writes: int = 0
    hostile_requests: int = 0
    hostile_accepted: int = 0
    problems: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)  # per operation

    def lines(self) -> list[str]:
        return [f"fuzz_requests: {self.requests}", f"fuzz_server_errors: {self.server_errors}",
                f"fuzz_schema_violations: {self.schema_violations}", f"fuzz_viewer_writes: {self.viewer_writes}",
                f"fuzz_hostile_requests: {self.hostile_requests}", f"fuzz_hostile_accepted: {self.hostile_accepted}"]

    @property
    def clean(self) -> bool:
        return self.server_errors == self.schema_violations == self.viewer_writes == self.hostile_accepted == 0


def api_token(base_url: str, username: str, password: str) -> str:
    request = urllib.request.Request(f"{base_url}/api/auth/token/", method="POST",
                                     data=json.dumps({"username": username, "password": password}).encode(),
                                     headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=10) as res:
        return json.load(res)["token"]


def fuzz_api(base_url: str, *, operator: tuple[str, str], viewer: tuple[str, str], max_examples: int) -> FuzzReport:
    """Fuzz as the operator, then as the viewer; then ask the audit log whether the viewer got
    any command through. Tokens first: the fuzzed token endpoint may lock this address out."""
    tokens = {role: api_token(base_url, *credentials) for role, credentials in
              (("operator", operator), ("viewer", viewer))}
    report = FuzzReport()
    fuzz(base_url, tokens["operator"], viewer=False, report=report, max_examples=max_examples)
    fuzz(base_url, tokens["viewer"], viewer=True, report=report, max_examples=max_examples)
    request = urllib.request.Request(f"{base_url}/api/audit/?user={viewer[0]}&outcome=ok&page_size=500",
                                     headers={"Authorization": f"Token {tokens['operator']}"})
    with urllib.request.urlopen(request, timeout=10) as res:
        accepted = [row["action"] for row in json.load(res)["results"] if row["action"] not in NOT_A_WRITE_ACTIONS]
    if accepted:
        report.viewer_writes += len(accepted)
        report.problems.append(f"viewer write: {len(accepted)} commands by {viewer[0]} succeeded (audit log): "
                               f"{sorted(set(accepted))}")
    return report


def fuzz(base_url: str, token: str, *, viewer: bool, report: FuzzReport, max_examples: int) -> FuzzReport:
    """Every operation of the live schema, schema-valid and invalid inputs, ``max_examples`` each."""
    headers = {"Authorization": f"Token {token}"}
    schema = schemathesis.openapi.from_url(f"{base_url}/api/schema/?format=json", headers=headers)
    # The viewer's run is about role checks: schema-valid requests are the ones that could get through.
    modes = (GenerationMode.POSITIVE,) if viewer else (GenerationMode.POSITIVE, GenerationMode.NEGATIVE)
    for result in schema.get_all_operations():
        operation = result.ok()
        for mode in modes:
            _fuzz_operation(operation, mode, base_url, headers, viewer, report, max_examples)
    return report


def _fuzz_operation(operation, mode, base_url, headers, viewer, report, max_examples) -> None:
    hostile_left = [HOSTILE_CASES if mode == GenerationMode.POSITIVE and not viewer else 0]

    @given(case=operation.as_strategy(generation_mode=mode))
    @hypothesis_settings(max_examples=max_examples, deadline=None, database=None, phases=[Phase.generate],
                         suppress_health_check=list(HealthCheck), derandomize=True)
    def run(case) -> None:
        started = time.monotonic()
        response = case.call(base_url=base_url, headers=headers, timeout=30)
        name = f"{case.method} {operation.path}"
        report.seconds[name] = report.seconds.get(name, 0.0) + time.monotonic() - started
        report.requests += 1
        where = f"{case.method} {case.formatted_path} -> {response.status_code}"
        if response.status_code >= 500:
            report.server_errors += 1
            report.problems.append(f"server error: {where}: {response.text[:300]}")
        if viewer and case.method.upper() in UNSAFE and 200 <= response.status_code < 300 \
                and (case.method.upper(), operation.path) not in NOT_A_WRITE:
            report.viewer_writes += 1
            report.problems.append(f"viewer write: {where}")
        try:
            case.validate_response(response, checks=SCHEMA_CHECKS)
        except (Failure, FailureGroup) as exc:
            report.schema_violations += 1
            report.problems.append(f"schema: {where}: {str(exc)[:600]}\n{case.as_curl_command()}")
        if hostile_left[0] > 0:
            hostile_left[0] -= 1
            _send_hostile(case, base_url, headers, report)

    try:
        run()
    except Unsatisfiable:
        pass  # nothing to generate in this mode (e.g. no parameters to make invalid)


def _send_hostile(case, base_url: str, headers: dict[str, str], report: FuzzReport) -> None:
    """``case`` once per hostile value in its JSON body and its query, as raw text."""
    sent = case.as_transport_kwargs(base_url=base_url, headers=headers)
    variants: list[dict[str, Any]] = []
    if "json" in sent:
        body = sent.pop("json")
        variants += [{"data": raw.encode(), "headers": {**sent["headers"], "Content-Type": "application/json"}}
                     for raw in hostile_json(body)]
    for name, value in (sent.get("params") or {}).items():
        variants += [{"params": {**sent["params"], name: hostile}}
                     for hostile in (*NON_FINITE, *(f"{value}{char}x" for char in EDGE_CHARACTERS))]
    for variant in variants:
        response = requests.request(**{**sent, **variant}, timeout=30)
        report.requests += 1
        report.hostile_requests += 1
        where = f"{case.method} {case.formatted_path} {str(variant)[:200]} -> {response.status_code}"
        if response.status_code >= 500:
            report.server_errors += 1
            report.problems.append(f"server error: {where}: {response.text[:300]}")
        elif "data" in variant and case.method.upper() in UNSAFE and response.status_code < 300 \
                and (case.method.upper(), case.operation.path) not in NOT_A_WRITE:
            report.hostile_accepted += 1
            report.problems.append(f"hostile value accepted: {where}: {response.text[:300]}")


def hostile_json(body: Any) -> Iterator[str]:
    """Raw JSON texts: ``body`` with one leaf at a time a non-finite number literal, and with one string
    at a time ending in each edge character (the whole body counts as a leaf)."""
    for path, leaf in _leaves(body):
        hole = json.dumps(_replaced(body, path, _HOLE))
        for literal in NON_FINITE:
            yield hole.replace(json.dumps(_HOLE), literal)
        if isinstance(leaf, str):
            for char in EDGE_CHARACTERS:
                yield json.dumps(_replaced(body, path, f"{leaf}{char}x"), ensure_ascii=False)


def _leaves(value: Any, path: tuple[Any, ...] = ()) -> Iterator[tuple[tuple[Any, ...], Any]]:
    if isinstance(value, dict | list) and value:
        for key, child in (value.items() if isinstance(value, dict) else enumerate(value)):
            yield from _leaves(child, (*path, key))
    else:
        yield path, value


def _replaced(value: Any, path: tuple[Any, ...], new: Any) -> Any:
    if not path:
        return new
    head, *rest = path
    copy = dict(value) if isinstance(value, dict) else list(value)
    copy[head] = _replaced(value[head], tuple(rest), new)
    return copy

"""Fuzz the live API from its own OpenAPI schema (schemathesis), once as an operator and once
as a viewer, and count what matters: requests, server errors, responses the schema does not
describe, and writes a viewer got through. Used by the suite (short run) and bench/fuzz.py."""

from __future__ import annotations

import json
import time
import urllib.request
from dataclasses import dataclass, field

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
# Not writes: a viewer may exchange its password for a token.
# Requests a viewer may make that change nothing of the robot's or anyone else's: a token of
# their own, their own map overlay choices.
NOT_A_WRITE = {("POST", "/api/auth/token/"), ("PATCH", "/api/me/map-overlays/")}


@dataclass
class FuzzReport:
    requests: int = 0
    server_errors: int = 0
    schema_violations: int = 0
    viewer_writes: int = 0
    problems: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)  # per operation

    def lines(self) -> list[str]:
        return [f"fuzz_requests: {self.requests}", f"fuzz_server_errors: {self.server_errors}",
                f"fuzz_schema_violations: {self.schema_violations}", f"fuzz_viewer_writes: {self.viewer_writes}"]


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
    request = urllib.request.Request(f"{base_url}/api/audit/?user={viewer[0]}&outcome=ok",
                                     headers={"Authorization": f"Token {tokens['operator']}"})
    with urllib.request.urlopen(request, timeout=10) as res:
        accepted = json.load(res)["count"]
    if accepted:
        report.viewer_writes += accepted
        report.problems.append(f"viewer write: {accepted} commands by {viewer[0]} succeeded (audit log)")
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

    try:
        run()
    except Unsatisfiable:
        pass  # nothing to generate in this mode (e.g. no parameters to make invalid)

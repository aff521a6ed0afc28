"""Fuzz the live API from its OpenAPI schema (schemathesis), as an operator and as a viewer.

Run: .venv/bin/python bench/fuzz.py  (starts its own simulator + Daphne; a few minutes)
Prints fuzz_requests, fuzz_server_errors, fuzz_schema_violations, fuzz_viewer_writes,
fuzz_hostile_requests (non-finite numbers and invisible characters, tests/fuzzing.py) and
fuzz_hostile_accepted (all but the two counts of requests must be 0) and the first problems found.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.fuzzing import fuzz_api
from tests.stack import PASSWORD, Stack

EXAMPLES_PER_OPERATION = 25


def main() -> int:
    with Stack() as stack:
        stack.wait_robot_online()
        report = fuzz_api(stack.url, operator=("otto", PASSWORD), viewer=("vera", PASSWORD),
                          max_examples=EXAMPLES_PER_OPERATION)
    print("\n".join(report.lines()))
    seen: set[str] = set()
    for problem in report.problems:  # the first of each kind, where and operation
        kind = " ".join(problem.split()[:4])
        if kind not in seen:
            seen.add(kind)
            print(problem, file=sys.stderr)
    return 0 if report.clean else 1


if __name__ == "__main__":
    sys.exit(main())

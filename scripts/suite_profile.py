"""Where a command's time goes, by kind of process: ``python scripts/suite_profile.py make test``.

Samples every process's CPU time twice a second while the command runs and prints the wall time,
the CPU seconds spent meanwhile (by every process on the machine, counted from when the command
started) and their split by kind of process. A process that lives less than half a second between
two samples is missed, so the figures are a little low.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from collections import defaultdict

HZ = os.sysconf("SC_CLK_TCK")
KINDS = [
    ("chromium", r"chromium"), ("playwright", r"playwright/driver"), ("daphne", r"daphne"),
    ("simulator", r"-m simulator"), ("robot link", r"robotlink"), ("celery", r"celery"), ("mypy", r"mypy"),
    ("ruff", r"ruff"), ("nginx", r"nginx"), ("redis", r"redis-server"), ("postgresql", r"postgres"),
    ("pytest worker", r"exec\(eval\(sys.stdin"), ("pytest", r"pytest"), ("manage.py", r"manage\.py"),
    ("install", r"\buv\b|\bpip\b|apt"), ("make, shells", r"^(make|bash|sh) "),
]


def kind_of(cmdline: str) -> str:
    for kind, pattern in KINDS:
        if re.search(pattern, cmdline):
            return kind
    return "other"


def sample() -> dict[tuple[str, str], tuple[str, float]]:
    """(pid, start time) → (kind, CPU seconds so far), for every process now."""
    seen = {}
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            with open(f"/proc/{pid}/cmdline") as f:
                cmdline = f.read().replace("\0", " ").strip()
        except OSError:
            continue
        if not cmdline:  # kernel threads
            continue
        seen[(pid, fields[19])] = (kind_of(cmdline), (int(fields[11]) + int(fields[12])) / HZ)
    return seen


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__)
        return 2
    before = sample()
    start = time.monotonic()
    proc = subprocess.Popen(argv)
    last: dict[tuple[str, str], tuple[str, float]] = dict(before)
    while proc.poll() is None:
        last.update(sample())
        time.sleep(0.5)
    wall = time.monotonic() - start
    by_kind: dict[str, float] = defaultdict(float)
    for key, (kind, cpu) in last.items():
        by_kind[kind] += cpu - before.get(key, (kind, 0.0))[1]
    total = sum(by_kind.values())
    print(f"suite_wall_s: {wall:.0f}")
    print(f"suite_cpu_s: {total:.0f}")
    print(f"suite_cores_busy: {total / wall:.2f} (of {os.cpu_count()})")
    for kind, cpu in sorted(by_kind.items(), key=lambda kv: -kv[1]):
        if cpu >= 1:
            print(f"  {kind}: {cpu:.0f} CPU s ({100 * cpu / total:.0f} %)")
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

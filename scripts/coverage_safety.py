"""The coverage of the safety code (E-STOP, latch, deadman, locks, liveness, lease), with its uncovered
lines named, from the combined data of both passes of ``make test``."""

from __future__ import annotations

import sys

import coverage

SAFETY = {
    "robot/estop/stop.py": "E-STOP",
    "robot/estop/latch.py": "latch",
    "robot/estop/rule.py": "E-STOP gate (what each command does under the latch)",
    "robot/estop/access.py": "E-STOP access with the database down",
    "robot/commands/audit_journal.py": "audit journal (the E-STOP's audit with the database down)",
    "robot/live/locks.py": "the drive and talk locks, the mode change's (in-process and on Redis)",
    "robot/link/liveness.py": "liveness (a robot that stops answering is sent nothing that moves it)",
    "robot/teleop/driver.py": "deadman (teleop loop)",
    "robot/teleop/driving.py": "drive sessions",
    "robot/teleop/session.py": "drive socket session",
    "robot/teleop/twist.py": "speed clamping",
    "robot/link/guard.py": "cmd_vel guard (deadman in the link)",
    "robot/link/lease.py": "link lease",
    "robot/link/direct.py": "the E-STOP's direct path to the links",
    "robot/link/standby.py": "a standby link's stop (runs in the link process)",
}


def main() -> int:
    cov = coverage.Coverage()
    cov.load()
    print("\nSafety code (line and branch):")
    for path, what in SAFETY.items():
        _, _, _, missing, missing_text = cov.analysis2(path)
        percent = cov.report(morfs=[path], file=_Null())
        where = f"  not run: {missing_text}" if missing else ""
        print(f"  {path:28} {percent:5.1f} %  {what}{where}")
    total = cov.report(file=_Null())
    print(f"\ncoverage_total_pct: {total:.1f}")
    return 0


class _Null:
    def write(self, _text: str) -> int:
        return 0


if __name__ == "__main__":
    sys.exit(main())

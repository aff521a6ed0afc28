"""The systemd units in deploy/systemd/, as `systemd-analyze security` rates them, and what they let
their processes write."""

from __future__ import annotations

import configparser
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.stack import ROOT

UNITS = ROOT / "deploy" / "systemd"
# A template is rated as one of its instances, named as cyborg.target names them.
INSTANCES = {"cyborg-web@.service": "cyborg-web@8001.service", "cyborg-link@.service": "cyborg-link@a.service"}
SERVICES = sorted(p.name for p in UNITS.glob("*.service"))
STATE_DIR = "/var/lib/cyborg"


def _service(name: str) -> configparser.SectionProxy:
    parser = configparser.ConfigParser(strict=False, interpolation=None, delimiters=("=",))
    parser.optionxform = str
    parser.read_string((UNITS / name).read_text())
    return parser["Service"]


def exposure(unit: Path) -> float:
    analyze = shutil.which("systemd-analyze") or "/usr/bin/systemd-analyze"
    out = subprocess.run([analyze, "security", "--offline=yes", str(unit)], capture_output=True, text=True,
                         timeout=60)
    found = re.search(r"Overall exposure level for \S+: (\d+\.\d+) ", out.stdout)
    assert found, out.stdout + out.stderr
    return float(found.group(1))


def test_every_unit_of_the_target_is_here():
    wants = configparser.ConfigParser(interpolation=None)
    wants.read_string((UNITS / "cyborg.target").read_text())
    templates = {re.sub(r"@[^.]+\.", "@.", unit) for unit in wants["Unit"]["Wants"].split()}
    assert templates == set(SERVICES)


@pytest.mark.parametrize("name", SERVICES)
def test_systemd_analyze_rates_the_unit_ok(tmp_path, name):
    unit = tmp_path / INSTANCES.get(name, name)
    shutil.copy(UNITS / name, unit)
    assert exposure(unit) <= 2.0


@pytest.mark.parametrize("name", SERVICES)
def test_the_code_is_read_only_and_only_the_state_directory_writable(name):
    service = _service(name)
    assert service["User"] == "cyborg" and service["WorkingDirectory"] == "/srv/cyborg/app"
    assert service["ProtectSystem"] == "strict"
    assert service["ProtectHome"] == "yes" and service["PrivateTmp"] == "yes"
    assert "/var/lib/" + service["StateDirectory"] == STATE_DIR
    for writable in ("ReadWritePaths", "BindPaths", "RuntimeDirectory", "LogsDirectory", "CacheDirectory"):
        assert writable not in service, f"{name} lets its process write {service[writable]}"
    # What it writes by name on its command line is in the state directory too (the beat's schedule).
    for path in re.findall(r"=(/\S+)", service["ExecStart"]):
        assert path.startswith(STATE_DIR + "/"), path


def test_the_example_environment_puts_var_dir_in_the_state_directory():
    env = (ROOT / "deploy" / "cyborg.env.example").read_text()
    assert re.search(r"^VAR_DIR=(\S+)$", env, re.MULTILINE).group(1) == STATE_DIR

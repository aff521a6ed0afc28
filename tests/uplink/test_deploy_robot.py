"""deploy/robot/: the agent's unit and example environment say what the agent reads."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from tests.deploy.test_units import exposure
from tests.stack import ROOT
from uplink_agent.__main__ import settings_from_env

ROBOT = ROOT / "deploy" / "robot"


def _example() -> dict[str, str]:
    pairs = re.findall(r"^#?(UPLINK_[A-Z_]+)=(.*)$", (ROBOT / "uplink.env.example").read_text(), re.M)
    return dict(pairs)


def test_every_setting_in_the_example_is_one_the_agent_reads() -> None:
    source = (ROOT / "uplink_agent" / "__main__.py").read_text()
    for name in _example():
        assert f'"{name}"' in source, f"{name} is in uplink.env.example but the agent never reads it"


def test_the_example_makes_valid_settings_and_a_plain_address_is_refused() -> None:
    env = {**_example(), "UPLINK_CREDENTIAL": "cyu_a_b"}
    made = settings_from_env(env)
    assert made.server_url.startswith("wss://") and made.deadman_s == 0.4
    with pytest.raises(ValueError, match="plain ws://"):
        settings_from_env({**env, "UPLINK_SERVER_URL": "ws://cyborg.example.org/uplink/"})
    with pytest.raises(ValueError, match="line breaks"):
        settings_from_env({**env, "UPLINK_CREDENTIAL": "cyu_a_b\nX-Injected: 1"})


@pytest.mark.skipif(shutil.which("systemd-analyze") is None, reason="no systemd-analyze here")
def test_systemd_analyze_rates_the_unit_ok(tmp_path) -> None:
    unit = tmp_path / "cyborg-uplink.service"
    # Its paths exist only on a robot: point them at ones that exist here.
    text = (ROBOT / "cyborg-uplink.service").read_text()
    unit.write_text(text.replace("/usr/bin/python3", shutil.which("python3") or "")
                    .replace("User=cyborg-uplink", "User=root").replace("Group=cyborg-uplink", "Group=root"))
    run = subprocess.run(["systemd-analyze", "verify", str(unit)], capture_output=True, text=True, timeout=60)
    problems = [line for line in run.stderr.splitlines() if "cyborg-uplink.service" in line]
    assert not problems, run.stderr
    assert exposure(unit) <= 2.0

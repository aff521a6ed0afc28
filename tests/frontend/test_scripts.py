"""The page scripts take every URL from the server-rendered configuration and share one live module."""

from __future__ import annotations

import re
from pathlib import Path

JS = Path(__file__).resolve().parents[2] / "static" / "js"
SCRIPTS = sorted(JS.rglob("*.js"))
# A string literal that starts like one of the site's paths ("/api/…", `/ws/…`, '/accounts/…').
URL_LITERAL = re.compile(r"""["'`]/(?:api|ws|accounts|video|history|map|drive|activity|admin)\b""")


def test_there_are_scripts_to_check():
    assert len(SCRIPTS) >= 10


def test_no_script_hard_codes_a_site_url():
    offenders = [f"{p.relative_to(JS)}:{n}" for p in SCRIPTS
                 for n, line in enumerate(p.read_text().splitlines(), 1) if URL_LITERAL.search(line)]
    assert offenders == []


def test_fetch_and_websockets_live_in_one_module_each():
    fetching = {p.name for p in SCRIPTS if "fetch(" in p.read_text()}
    assert fetching == {"api.js"}
    live_sockets = {p.name for p in SCRIPTS if "new WebSocket(" in p.read_text()}
    # the live socket, the drive page's teleop socket, its audio socket
    assert live_sockets == {"live.js", "drive.js", "audio.js"}


def test_pages_share_state_through_imports_not_globals():
    for p in SCRIPTS:
        text = p.read_text()
        assert "window.cyborgLive" not in text, p.name
        assert "CustomEvent(" not in text, p.name

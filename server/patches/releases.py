"""The exact Daphne, Twisted and autobahn releases the server patches were written and measured
against (this package's modules and ``install``, and ``cyborg_site.drain``; each says why it is
there, ``docs/performance.md`` what it saves). Another release may have changed what they touch,
so the server refuses to start on one: check the patches against it
(``tests/site/test_server_patches.py`` names every private part they use), then move these pins
and the lock together.
"""

from __future__ import annotations

from importlib.metadata import version
from typing import Any

from django.core import checks

PATCHED_RELEASES = {"daphne": "4.2.3", "twisted": "26.10.0", "autobahn": "26.10.2"}


def other_releases() -> dict[str, str]:
    """The installed release of each patched package that is not the one the patches were made for."""
    return {name: found for name, wanted in PATCHED_RELEASES.items() if (found := version(name)) != wanted}


def refuse_other_releases() -> None:
    others = other_releases()
    if others:
        found = ", ".join(f"{name} {v} (the patches are for {PATCHED_RELEASES[name]})" for name, v in others.items())
        raise RuntimeError(f"The server patches do not know {found}: see server/patches/releases.py.")


def check_patched_server_releases(app_configs: Any, **kwargs: Any) -> list[checks.CheckMessage]:
    """The server refuses to start on other releases (server.asgi); say so before it does."""
    return [checks.Error(f"{name} {found} is installed; the server patches are for {PATCHED_RELEASES[name]}",
                         hint="see server/patches/releases.py", id="server.E001")
            for name, found in other_releases().items()]

"""The exact Daphne, Twisted and autobahn releases the server patches were written and measured
against (this package's modules and ``install``, and ``cyborg_site.drain``; each says why it is
there, ``docs/performance.md`` what it saves). Another release may have changed what they touch,
so the server refuses to start on one: check the patches against it
(``tests/site/test_server_patches.py`` names every private part they use), then move these pins
and the lock together.
"""

from __future__ import annotations

from importlib.metadata import version

PATCHED_RELEASES = {"daphne": "4.2.3", "twisted": "26.10.0", "autobahn": "26.10.2"}


def other_releases() -> dict[str, str]:
    """The installed release of each patched package that is not the one the patches were made for."""
    return {name: found for name, wanted in PATCHED_RELEASES.items() if (found := version(name)) != wanted}


def refuse_other_releases() -> None:
    others = other_releases()
    if others:
        found = ", ".join(f"{name} {v} (the patches are for {PATCHED_RELEASES[name]})" for name, v in others.items())
        raise RuntimeError(f"The server patches do not know {found}: see cyborg_site/server_patches/releases.py.")

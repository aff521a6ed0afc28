"""Exact library releases that some code's use of their private parts was written for.

Code that reaches into a library's internals declares the releases it was checked against; its
process refuses to start on others (``refuse_others``) and ``manage.py check`` says so first
(``register_check``). A canary test per private part fails first when an upgrade changes one.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib.metadata import version
from typing import Any

from django.core import checks


@dataclass(frozen=True)
class Pinned:
    users: str  # what uses the private parts, e.g. "the server patches"
    releases: dict[str, str]  # distribution name -> the exact release
    see: str  # the module that says why, and what to check before moving a pin
    check_id: str

    def others(self) -> dict[str, str]:
        """The installed release of each pinned package that is not the pinned one."""
        return {name: found for name, wanted in self.releases.items() if (found := version(name)) != wanted}

    def _mismatches(self) -> list[str]:
        return [f"{name} {found} is installed, but {self.users} are for {self.releases[name]}"
                for name, found in self.others().items()]

    def refuse_others(self) -> None:
        if mismatches := self._mismatches():
            raise RuntimeError(f"{'; '.join(mismatches)}: see {self.see}.")

    def register_check(self) -> None:
        """A system check error for each release ``refuse_others`` would refuse."""

        def check(app_configs: Any, **kwargs: Any) -> list[checks.CheckMessage]:
            return [checks.Error(mismatch, hint=f"see {self.see}", id=self.check_id) for mismatch in self._mismatches()]

        checks.register(check)

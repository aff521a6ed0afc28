"""The system check that refuses a placeholder or weak SECRET_KEY (cyborg_site.checks)."""

from __future__ import annotations

import os
import secrets
import subprocess

import pytest
from django.core import checks

from tests.stack import PYTHON, ROOT

GOOD = secrets.token_urlsafe(50)
EXAMPLE = next(line.split("=", 1)[1] for line in (ROOT / "deploy" / "cyborg.env.example").read_text().splitlines()
               if line.startswith("SECRET_KEY="))


def _ids(*, deploy: bool) -> list[str]:
    return [m.id for m in checks.run_checks(tags=[checks.Tags.security], include_deployment_checks=deploy)
            if m.id == "cyborg_site.E001" and m.is_serious()]


@pytest.mark.parametrize("key", [
    "",
    "x" * 49 + "",
    "ab" * 40,
    "django-insecure-" + GOOD,
    EXAMPLE,
    GOOD[:30] + "changeme" + GOOD[30:],
    GOOD[:30] + "Change_Me" + GOOD[30:],
    GOOD + "-PLACEHOLDER",
    "example" + GOOD,
    GOOD + "secret-key",
], ids=["empty", "short", "four-characters", "startproject", "the-example", "changeme", "change_me",
        "placeholder", "example", "secret-key"])
def test_a_weak_or_placeholder_key_is_an_error_with_debug_off(settings, key):
    settings.DEBUG = False
    settings.SECRET_KEY = key
    assert _ids(deploy=False) == ["cyborg_site.E001"]
    assert _ids(deploy=True) == ["cyborg_site.E001"]  # once, not once per registration


def test_a_generated_key_passes(settings):
    settings.DEBUG = False
    settings.SECRET_KEY = GOOD
    assert _ids(deploy=False) == _ids(deploy=True) == []


def test_with_debug_on_only_the_deployment_checks_refuse_it(settings):
    settings.DEBUG = True
    settings.SECRET_KEY = EXAMPLE
    assert _ids(deploy=False) == []
    assert _ids(deploy=True) == ["cyborg_site.E001"]


def _manage(*args: str, debug: bool) -> subprocess.CompletedProcess:
    env = {**{k: v for k, v in os.environ.items() if not k.startswith(("DJANGO_", "PYTEST_"))},
           "SECRET_KEY": EXAMPLE, "DEBUG": str(debug).lower()}
    return subprocess.run([PYTHON, "manage.py", *args], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=120)


@pytest.mark.parametrize(("args", "debug", "refused"), [
    (("check",), False, True),
    (("check",), True, False),
    (("check", "--deploy"), True, True),
])
def test_manage_py_check_refuses_the_examples_key(args, debug, refused):
    out = _manage(*args, debug=debug)
    assert (out.returncode != 0) is refused, out.stdout + out.stderr
    assert ("cyborg_site.E001" in out.stderr) is refused, out.stdout + out.stderr

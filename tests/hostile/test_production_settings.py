"""Production hardening from the environment: with the documented variables set, Django's
deployment checks report nothing; bad values fail at start-up."""

from __future__ import annotations

import os
import secrets
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# As documented in the README's configuration table.
PRODUCTION = {
    "DEBUG": "false",
    "ALLOWED_HOSTS": "cyborg.example.org",
    "SECURE_SSL_REDIRECT": "true",
    "SECURE_HSTS_SECONDS": "31536000",
    "SECURE_HSTS_INCLUDE_SUBDOMAINS": "true",
    "SECURE_HSTS_PRELOAD": "true",
    "SESSION_COOKIE_SECURE": "true",
    "CSRF_COOKIE_SECURE": "true",
    "SECURE_PROXY_SSL_HEADER": "HTTP_X_FORWARDED_PROTO,https",
    "CSRF_TRUSTED_ORIGINS": "https://cyborg.example.org",
}


def manage(*args: str, env: dict[str, str], tmp_path: Path) -> subprocess.CompletedProcess:
    full = {**os.environ, "VAR_DIR": str(tmp_path), **env}
    return subprocess.run([sys.executable, "manage.py", *args], cwd=ROOT, env=full, capture_output=True,
                          text=True, timeout=120)


def test_check_deploy_reports_nothing_with_the_production_variables(tmp_path):
    result = manage("check", "--deploy", "--fail-level", "WARNING",
                    env={**PRODUCTION, "SECRET_KEY": secrets.token_urlsafe(50)}, tmp_path=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "System check identified no issues (0 silenced)." in result.stdout


def test_check_deploy_warns_without_them(tmp_path):
    result = manage("check", "--deploy", env={"DEBUG": "false", "SECRET_KEY": secrets.token_urlsafe(50)},
                    tmp_path=tmp_path)
    for warning in ("security.W004", "security.W008", "security.W012", "security.W016"):
        assert warning in result.stdout + result.stderr


def test_the_settings_follow_the_variables(tmp_path):
    code = ("from django.conf import settings as s; print(s.SECURE_SSL_REDIRECT, s.SECURE_HSTS_SECONDS, "
            "s.SECURE_PROXY_SSL_HEADER, s.CSRF_TRUSTED_ORIGINS, s.SESSION_COOKIE_SECURE)")
    result = manage("shell", "-c", code, env={**PRODUCTION, "CSRF_TRUSTED_ORIGINS": "https://a.org, https://b.org"},
                    tmp_path=tmp_path)
    assert result.stdout.split("\n")[-2] == (
        "True 31536000 ('HTTP_X_FORWARDED_PROTO', 'https') ['https://a.org', 'https://b.org'] True"), result.stderr


@pytest.mark.parametrize(("name", "value"), [("SECURE_PROXY_SSL_HEADER", "https"), ("SECURE_HSTS_SECONDS", "a year"),
                                             ("SESSION_COOKIE_SECURE", "maybe")])
def test_bad_values_fail_loudly_at_start_up(tmp_path, name, value):
    result = manage("check", env={name: value}, tmp_path=tmp_path)
    assert result.returncode != 0 and name in result.stderr


def test_the_schema_generates_without_warnings(tmp_path):
    result = manage("spectacular", "--fail-on-warn", "--file", str(tmp_path / "schema.yaml"), env={},
                    tmp_path=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr

"""Shared by the history benches: run a function in a child process per database backend.

Django is set up once per process, so each backend (a temp SQLite file, a throwaway
PostgreSQL database) gets a child process of its own with only history's tables.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PG_SERVER = "postgres://postgres@127.0.0.1:5432"
PG_BENCH_DB = "cyborg_bench"


def _pg(sql: str) -> None:
    import psycopg

    with psycopg.connect(f"{PG_SERVER}/postgres", autocommit=True) as conn:
        conn.execute(sql)


def run_per_backend(script: str) -> dict[str, dict]:
    """Run ``script --child`` once for SQLite and once for PostgreSQL; collect their JSON results."""
    results: dict[str, dict] = {}
    with tempfile.TemporaryDirectory(prefix="history-bench-") as tmp:
        backends = {"sqlite": f"sqlite:///{tmp}/bench.sqlite3", "postgresql": f"{PG_SERVER}/{PG_BENCH_DB}"}
        for name, url in backends.items():
            if name == "postgresql":
                try:
                    _pg(f"DROP DATABASE IF EXISTS {PG_BENCH_DB}")
                    _pg(f"CREATE DATABASE {PG_BENCH_DB}")
                except Exception as exc:
                    print(f"# postgresql skipped: {exc}", file=sys.stderr)
                    continue
            env = {**os.environ, "DATABASE_URL": url, "VAR_DIR": tmp, "DJANGO_SETTINGS_MODULE": "cyborg_site.settings",
                   "LOG_LEVEL": "WARNING"}
            env.pop("REDIS_URL", None)
            try:
                out = subprocess.run([sys.executable, script, "--child"], env=env, cwd=ROOT, check=True,
                                     capture_output=True, text=True, timeout=120)
                results[name] = json.loads(out.stdout.strip().splitlines()[-1])
            except subprocess.CalledProcessError as exc:
                print(exc.stderr[-3000:], file=sys.stderr)
                raise
            finally:
                if name == "postgresql":
                    _pg(f"DROP DATABASE IF EXISTS {PG_BENCH_DB} WITH (FORCE)")
    return results


def setup_child() -> None:
    """In the child: Django up, history's tables created (no full migrate: faster, nothing else needed)."""
    sys.path.insert(0, str(ROOT))
    import django

    django.setup()
    from django.db import connection

    from history.models import RecordingSettings, Rollup, Sample, TopicPolicy

    with connection.schema_editor() as editor:
        for model in (RecordingSettings, TopicPolicy, Sample, Rollup):
            editor.create_model(model)

#!/usr/bin/env bash
# The whole suite twice: on the embedded default (SQLite, in-memory channel layer) and on
# the machine's real services (PostgreSQL, Redis channel layer, Celery on Redis).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=.venv/bin

ensure_services() {
  if ! $BIN/python -c "import socket; socket.create_connection(('127.0.0.1', 6379), 1)" 2>/dev/null; then
    echo "Redis is down; starting it"
    redis-server --daemonize yes --bind 127.0.0.1 -::1 --port 6379 --save "" --appendonly no \
      --dir /var/lib/redis --logfile /var/log/redis/ci.log || true
  fi
  if ! $BIN/python -c "import socket; socket.create_connection(('127.0.0.1', 5432), 1)" 2>/dev/null; then
    echo "PostgreSQL is down; starting it"
    pg_ctlcluster --skip-systemctl-redirect "$(ls /etc/postgresql)" main start || true
  fi
}
ensure_services

$BIN/ruff check .
env -u REDIS_URL -u DATABASE_URL $BIN/mypy  # robot/ and cyborg_site/, configured in pyproject.toml

echo "== Embedded default: SQLite + in-memory channel layer"
env -u REDIS_URL -u DATABASE_URL $BIN/python -m pytest "$@"

echo "== Services: PostgreSQL + Redis"
DATABASE_URL=${TEST_DATABASE_URL:-postgres://postgres@127.0.0.1:5432/test} \
REDIS_URL=${TEST_REDIS_URL:-redis://127.0.0.1:6379/15} \
  $BIN/python -m pytest -m "not browser" "$@"

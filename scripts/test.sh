#!/usr/bin/env bash
# The whole suite: lint and types, then the tests on two wirings, spread over parallel workers:
#   embedded  SQLite + a private Valkey server per process: every test;
#   services  PostgreSQL + Redis: the tests marked as depending on the engine or on a shared Redis
#             (tests/wiring.py says which).
# The browser tests run on two workers (two groups: one stack and Chromium each). Ends with line and
# branch coverage of all runs together and the time each part took. Arguments go to every pytest run (scripts/test.sh tests/teleop -x).
# TEST_WORKERS sets the workers of the non-browser runs; TEST_LINT=0 and TEST_COVERAGE=0 skip those.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=.venv/bin
WORKERS=${TEST_WORKERS:-2}
COVERAGE=${TEST_COVERAGE:-$([ $# -eq 0 ] && echo 1 || echo 0)}  # a developer's quick run skips it
LOGS=var/test-logs

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

# pytest with coverage into a data file of its own (combined at the end); exit 5 (the arguments chose
# none of this run's tests) counts as passing.
run_pytest() {
  local name=$1 status=0
  shift
  local cov=()
  [ "$COVERAGE" = 1 ] && cov=(--cov --cov-report=)
  COVERAGE_FILE=var/coverage/.coverage.$name $BIN/python -m pytest "${cov[@]}" "$@" || status=$?
  [ $status = 5 ] && status=0
  return $status
}
embedded() { (unset REDIS_URL DATABASE_URL; "$@"); }
services() {
  (export DATABASE_URL=${TEST_DATABASE_URL:-postgres://postgres@127.0.0.1:5432/test}
   export REDIS_URL=${TEST_REDIS_URL:-redis://127.0.0.1:6379/15}
   "$@")
}
lint() {
  [ "${TEST_LINT:-1}" = 1 ] || return 0
  $BIN/ruff check . && env -u REDIS_URL -u DATABASE_URL $BIN/mypy && $BIN/lint-imports --no-cache
}

times=()
part() {  # part TITLE COMMAND…: runs it, streaming its output, and keeps its time and verdict
  local title=$1 start=$SECONDS status=0
  shift
  echo "== $title"
  "$@" || status=$?
  times+=("$title: $((SECONDS - start)) s$([ $status = 0 ] || echo ", FAILED (exit $status)")")
  return $status
}

ensure_services
rm -rf "$LOGS" && mkdir -p "$LOGS"
[ "$COVERAGE" = 1 ] && rm -rf var/coverage
mkdir -p var/coverage
start=$SECONDS
status=0

# Lint, types and layers beside the first part: mypy is one process, and much of a test part is waiting.
lint_start=$SECONDS
(lint > "$LOGS/lint.log" 2>&1; echo $? > "$LOGS/lint.status"; echo $((SECONDS - lint_start)) > "$LOGS/lint.s")&
lint_pid=$!
part "Embedded default: SQLite + private Valkey, all but the browser tests" \
  embedded run_pytest embedded -m "not browser" -n "$WORKERS" "$@" || status=1
part "Embedded default: the browser tests (headless Chromium, two groups)" \
  embedded run_pytest browser -m browser -n 2 --dist loadgroup "$@" || status=1
part "Services: PostgreSQL + Redis, the tests that depend on the wiring" \
  services run_pytest services -m "wiring and not browser and not stack" -n "$WORKERS" "$@" || status=1
# The production topology (nginx, two Daphne, two links, Celery) times its own failovers and drains:
# it runs alone, with nothing else competing for the two cores.
part "Services: the production topology, alone" services run_pytest topology -m stack "$@" || status=1
wait $lint_pid || true
echo "== Lint, types and layers (ruff, mypy, lint-imports)"
cat "$LOGS/lint.log"
lint_status=$(cat "$LOGS/lint.status")
times=("Lint, types and layers (ruff, mypy, lint-imports), beside the first part: $(cat "$LOGS/lint.s") s$([ "$lint_status" = 0 ] \
  || echo ", FAILED (exit $lint_status)")" "${times[@]}")
[ "$lint_status" = 0 ] || status=1

if [ "$COVERAGE" = 1 ]; then
  echo "== Coverage of all runs together (application code, line and branch)"
  export COVERAGE_FILE=var/coverage/.coverage
  $BIN/coverage combine -q var/coverage/.coverage.* && $BIN/python scripts/coverage_safety.py || status=1
  echo "(every file: .venv/bin/coverage report, or html; data in var/coverage/)"
fi

echo
echo "== Times"
printf '%s\n' "${times[@]}"
echo "whole suite: $((SECONDS - start)) s"
exit $status

# Two commands for a fresh machine:  make run  and  make test.
# Python 3.12 or newer: found on PATH or in pyenv (scripts/find-python.sh says how to get one).
PY ?= $(shell bash scripts/find-python.sh)
VENV := .venv
BIN := $(VENV)/bin
PORT ?= 8000
SIM_PORT ?= 9090
VIDEO_PORT ?= 8080
# The simulated robot's ROS: 1, or 2 (Jazzy, rosbridge 2.x, Nav2); the server finds out which.
ROS ?= 1
# The server talks to the simulator `make run` starts, unless told otherwise.
ROSBRIDGE_URL ?= ws://127.0.0.1:$(SIM_PORT)
VIDEO_URL ?= http://127.0.0.1:$(VIDEO_PORT)
STAMP := $(VENV)/.installed
# Python caches compiled modules only where it may write them: without the cache every process the
# suite starts (Daphne, links, the simulator, manage.py) compiles all it imports again, ~5 CPU s each.
unexport PYTHONDONTWRITEBYTECODE

.PHONY: run test test-quick test-repeat install browser nginx wrk stress-ng stack stack-down lint bench clean

# Installs exactly what requirements/dev.lock pins, with hashes. Upgrading is on purpose:
#   .venv/bin/uv pip compile pyproject.toml --extra dev --generate-hashes --python-version 3.12 \
#     --upgrade -o requirements/dev.lock
$(STAMP): requirements/dev.lock requirements/bootstrap.lock
	@test -n "$(PY)" || { echo "No Python 3.12 or newer: see above." >&2; exit 1; }
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --disable-pip-version-check --require-hashes -r requirements/bootstrap.lock
	$(BIN)/uv pip sync -q --python $(BIN)/python --require-hashes requirements/dev.lock
	$(BIN)/uv pip install -q --python $(BIN)/python --no-deps --no-build-isolation -e .
	touch $(STAMP)

install: $(STAMP)

# Debian's Chromium for the browser tests (Playwright drives it through executablePath): its headless
# shell for most, the whole browser where a test needs its UI (permission prompts).
browser:
	@command -v chromium >/dev/null 2>&1 && command -v chromium-headless-shell >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -qq && apt-get install -y -qq chromium chromium-headless-shell; \
	  else sudo apt-get update -qq && sudo apt-get install -y -qq chromium chromium-headless-shell; fi; }

# Debian's nginx (and openssl for the self-signed certificate) for scripts/stack.sh and its tests.
nginx:
	@{ command -v nginx || test -x /usr/sbin/nginx; } >/dev/null 2>&1 && command -v openssl >/dev/null 2>&1 && command -v curl >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -qq && apt-get install -y -qq nginx openssl curl; \
	  else sudo apt-get update -qq && sudo apt-get install -y -qq nginx openssl curl; fi; }

# Debian's wrk: the C load generator bench/api_throughput.py drives the state API with.
wrk:
	@command -v wrk >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -qq && apt-get install -y -qq wrk; \
	  else sudo apt-get update -qq && sudo apt-get install -y -qq wrk; fi; }

# Debian's stress-ng: the CPU hog beside the suite in make test-repeat HOG=1.
stress-ng:
	@command -v stress-ng >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -qq && apt-get install -y -qq stress-ng; \
	  else sudo apt-get update -qq && sudo apt-get install -y -qq stress-ng; fi; }

# The production topology on this machine (see README, "Deploy").
stack: install nginx
	bash scripts/stack.sh up

stack-down:
	bash scripts/stack.sh down

run: install
	$(BIN)/python manage.py migrate --noinput
	$(BIN)/python manage.py bootstrap
	@echo "Simulated ROS $(ROS) robot on ws://127.0.0.1:$(SIM_PORT), server talks to $(ROSBRIDGE_URL); open http://127.0.0.1:$(PORT)/"
	@bash scripts/run.sh '$(BIN)' '$(PORT)' '$(SIM_PORT)' '$(VIDEO_PORT)' '$(ROSBRIDGE_URL)' '$(VIDEO_URL)' '$(ROS)'

# Foxglove's own message decoders, for the front door's tests (test-only, pinned by their lock file).
FOXGLOVE := tests/frontdoor/foxglove
$(FOXGLOVE)/node_modules/.installed: $(FOXGLOVE)/package-lock.json
	npm ci --prefix $(FOXGLOVE) --no-audit --no-fund --loglevel=error
	touch $@

test: install browser nginx $(FOXGLOVE)/node_modules/.installed
	bash scripts/test.sh

# While working: the tests a change touched (pytest-testmon: it remembers which code each test ran, in
# .testmondata; the first run, with none yet, runs them all; -m would switch its selection off without
# --testmon-forceselect). Embedded wiring, neither the browser nor
# the topology tests; make test stays the whole suite.
test-quick: install $(FOXGLOVE)/node_modules/.installed
	env -u REDIS_URL -u DATABASE_URL $(BIN)/python -m pytest --testmon --testmon-forceselect -m "not browser and not stack" -n 2 -q $(ARGS)

# The suite N times (make test-repeat N=5): which tests ever failed, and how often. HOG=1 keeps one
# core busy beside every run (stress-ng --cpu 1), as a loaded machine would; ARGS go to every pytest run.
N ?= 5
HOG ?= 0
test-repeat: install browser nginx $(FOXGLOVE)/node_modules/.installed $(if $(filter 1,$(HOG)),stress-ng)
	HOG=$(HOG) bash scripts/test_repeat.sh $(N) $(ARGS)

lint: install
	$(BIN)/ruff check .
	env -u REDIS_URL -u DATABASE_URL $(BIN)/mypy
	$(BIN)/lint-imports --no-cache

bench: install wrk
	for b in bench/*.py; do echo "== $$b"; $(BIN)/python $$b; done

clean:
	rm -rf $(VENV) var .pytest_cache

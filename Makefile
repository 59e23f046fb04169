# wheelscan — the README's two commands (`make run`, `make test`) set everything up from scratch.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
APT_STAMP := $(VENV)/.apt-installed
NODE_STAMP := node_modules/.installed
KERNEL_STAMP := $(VENV)/.kernels-compiled
PIPELINE_SOURCES := $(shell find pipeline -name '*.py')
DEBIAN_PACKAGES := chromium poppler-utils fonts-dejavu-core docker-compose nodejs postgresql redis-server

.PHONY: run test lint format bench venv system-deps node-tools clean

venv: $(STAMP)

$(STAMP): pyproject.toml requirements.lock
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -c requirements.lock -e '.[dev]'
	touch $(STAMP)

# The numba kernels, compiled again whenever a pipeline source changes (precompile clears
# every cached kernel first when any source differs from the last compile).
$(KERNEL_STAMP): $(STAMP) $(PIPELINE_SOURCES)
	$(PY) -m pipeline.precompile
	touch $(KERNEL_STAMP)

# Debian packages the tests need: headless Chromium, pdftoppm, and the PostgreSQL and Redis
# binaries the tests start throw-away servers from when the machine runs none.
system-deps: $(APT_STAMP)

$(APT_STAMP): Makefile | $(STAMP)
	@missing=""; for p in $(DEBIAN_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing >/dev/null; \
	fi
	touch $(APT_STAMP)

# The front end's development tools (tsc, prettier), pinned in package-lock.json; the
# product itself has no build step and never loads them.
node-tools: $(NODE_STAMP)

$(NODE_STAMP): package.json package-lock.json | $(APT_STAMP)
	@command -v npm >/dev/null || { SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq npm >/dev/null; }
	npm ci --no-audit --no-fund --loglevel=error
	touch $(NODE_STAMP)

run: $(STAMP) $(KERNEL_STAMP)
	$(VENV)/bin/wheelscan run-demo

lint: $(STAMP) $(NODE_STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy
	$(PY) scripts/api_types.py --check
	node_modules/.bin/tsc -p tsconfig.json
	node_modules/.bin/prettier --check frontend tests/frontend

# Rewrites files in place: Python with ruff, the front end's JavaScript with prettier.
format: $(STAMP) $(NODE_STAMP)
	$(VENV)/bin/ruff format .
	node_modules/.bin/prettier --write frontend tests/frontend

# Test files run on one worker process per core (at most 4), each file's tests on one worker
# in order (their module fixtures, e.g. a browser test's service, are made once).
test: $(STAMP) $(KERNEL_STAMP) system-deps lint
	$(PY) -m pytest -q -n auto --maxprocesses 4 --dist loadfile

bench: $(STAMP) $(KERNEL_STAMP)
	$(PY) -m benchmarks.run

clean:
	rm -rf $(VENV) node_modules data .pytest_cache .hypothesis

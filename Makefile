# Two entry points that work on a fresh machine with Python 3.11, pip and make.
PYTHON ?= python3.11
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: demo test check lint venv clean chromium

# The packages go in with uv (itself installed by pip from the package registry into the
# venv), their bytecode compiled at install as pip does: the test environment took 18 s
# with it against 53 s with pip (49 s the install, 4 s upgrading pip) on a fresh clone of
# this 2-core machine. pip does it when uv cannot.
INSTALL = { $(BIN)/uv pip install --quiet --compile-bytecode --python $(BIN)/python $(1) \
            || $(BIN)/python -m pip install --quiet $(1); }

$(BIN)/python:
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "error: $(PYTHON) not found; set PYTHON=/path/to/python3.11"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet uv || echo "note: uv not installed; installing with pip (slower)"

$(VENV)/.installed-test: $(BIN)/python pyproject.toml
	$(call INSTALL,-e ".[test]")
	@touch $@

$(VENV)/.installed: $(BIN)/python pyproject.toml
	$(call INSTALL,-e .)
	@touch $@

venv: $(VENV)/.installed

demo: $(VENV)/.installed
	$(BIN)/fingerfriction demo

lint: $(VENV)/.installed-test
	$(BIN)/ruff check src tests benchmarks

# Headless Chromium (Debian's package) for the HTML report test; installed when missing and
# we are root with apt-get (CI), otherwise the report test fails with a message saying so.
# One line says what is happening and why; apt's own output goes to $(CHROMIUM_LOG).
CHROMIUM_LOG ?= .chromium-install.log
chromium:
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "installing Debian's chromium (headless browser for the HTML report test; apt output in $(CHROMIUM_LOG))"; \
	    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; } >$(CHROMIUM_LOG) 2>&1 \
	      || { echo "error: installing chromium failed; see $(CHROMIUM_LOG)"; exit 1; }; \
	  else echo "note: chromium not found; install Debian's chromium package for the HTML report test"; fi; }

# Tests run on every core (pytest-xdist): the whole suite in `make test` (CI), the fast tier
# (everything not marked slow) in `make check` for everyday work. One worker more than the
# cores: much of the suite waits on processes it starts (the analysis' cluster, the CLI in a
# subprocess, Chromium), and a third worker on 2 cores fills those waits. Measured on fresh
# clones of this quiet 2-core machine, with the workers started from a forkserver
# (fingerfriction._workers): pytest 430 s with 3 workers against 490 s with 2. (With the
# former spawned workers it was the other way round, 553 s against 522 s.) Override with
# `make test TEST_WORKERS=N`.
TEST_WORKERS ?= $(shell echo $$(( $$(getconf _NPROCESSORS_ONLN 2>/dev/null || echo 1) + 1 )))
test: $(VENV)/.installed-test lint chromium
	$(BIN)/python -m pytest -n $(TEST_WORKERS)

check: $(VENV)/.installed-test lint
	$(BIN)/python -m pytest -n $(TEST_WORKERS) -m "not slow"

clean:
	rm -rf $(VENV) build src/*.egg-info .pytest_cache .ruff_cache $(CHROMIUM_LOG)

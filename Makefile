# thermogym — one target per check. `make test` and `make demo` work on a fresh machine:
# they create .venv and install what they need on first use.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
STAMP  := $(VENV)/.installed-test
STAMP_ALL := $(VENV)/.installed-all
EXTRAS := test,rl
OUT    ?= out

.PHONY: help install install-all test test-all firmware-test demo lint format bench clean

help:
	@echo "make demo      run the main job (thermogym demo) into $(OUT)/report.html"
	@echo "make test      run the default test suite (installs into .venv on first use)"
	@echo "make test-all  run every test, slow ones and optional tools included"
	@echo "make lint      ruff check + format check + mypy (type check of the package)"
	@echo "make bench     run the benchmarks in benchmarks/"

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)

# The local CPU build of PyTorch is installed first when this machine has it, so that the
# `rl` extra never pulls the registry's CUDA build (several GB).
$(STAMP): pyproject.toml | $(VENV)/bin/python
	$(PIP) install --no-index --no-deps "torch==2.13.0" >/dev/null 2>&1 \
		&& $(PIP) install "torch==2.13.0" \
		&& echo "installed local CPU build torch==2.13.0" \
		|| echo "no local torch==2.13.0 wheel; the rl extra will take torch from the registry"
	$(PIP) install -e ".[$(EXTRAS)]"
	touch $@

install: $(STAMP)

# Optional system tools for the optional tests: GNU Octave (external .m models), Chromium and
# chromedriver (the demo report rendered in a headless browser). Installed
# with apt-get where we may (root); otherwise those tests skip with their reason.
$(STAMP_ALL): $(STAMP)
	$(PIP) install -e ".[$(EXTRAS),all]"
	@command -v octave >/dev/null || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
		&& apt-get install -y --no-install-recommends octave >/dev/null \
		|| echo "octave not installed: its tests will skip"; }
	@{ command -v chromium >/dev/null && command -v chromedriver >/dev/null; } \
		|| { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
		&& apt-get install -y --no-install-recommends chromium chromium-driver >/dev/null; } \
		|| echo "chromium not installed: the report's browser test will skip"
	touch $@

install-all: $(STAMP_ALL)

test: $(STAMP)
	$(PY) -m pytest -m "not slow" -q

test-all: $(STAMP_ALL)
	$(PY) -m pytest -q
	$(MAKE) -C firmware test

# Host build and tests of the C firmware (and the AVR build under simavr when available).
firmware-test:
	$(MAKE) -C firmware test

# The main job: the whole loop on embedded defaults -> $(OUT)/report.html and report.md.
# Its firmware stage builds the ATmega328P part and runs it under simavr: the AVR tools
# (gcc-avr, avr-libc, simavr) are installed with apt-get where we may (root), as
# firmware/Makefile does; elsewhere that step prints why and the demo runs the host build
# only (its report says "AVR build not run" and how to get it).
demo: $(STAMP)
	@$(MAKE) --no-print-directory -C firmware avr-tools
	$(VENV)/bin/thermogym demo --out $(OUT) $(DEMO_ARGS)

lint: $(STAMP)
	$(VENV)/bin/ruff check thermogym tests benchmarks scripts
	$(VENV)/bin/ruff format --check thermogym tests benchmarks scripts
	$(VENV)/bin/mypy

format: $(STAMP)
	$(VENV)/bin/ruff format thermogym tests benchmarks scripts
	$(VENV)/bin/ruff check --fix thermogym tests benchmarks scripts

BENCH_OUT ?= $(OUT)/bench

# Each benchmark prints its ratio against a named peer and writes its figures as JSON.
bench: $(STAMP_ALL)
	@for b in simulate n4sid global_fit strut_study axt211_greybox env_throughput year firmware virtual_sensor bad_input; do \
		[ -f benchmarks/$$b.py ] || continue; \
		echo "== benchmarks/$$b.py"; $(PY) benchmarks/$$b.py --json $(BENCH_OUT)/$$b.json || exit 1; \
	done

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .ruff_cache .mypy_cache

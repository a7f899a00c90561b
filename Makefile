# Two commands set up a fresh machine (only Python needed):
#   make run    - create .venv, install, run the headline job -> results/ (its outputs are not tracked: git status
#                 stays clean; the tracked tables under results/ are the long checks' and benchmarks', each with its
#                 command)
#   make test   - create .venv, install, lint, run the tests CI runs (default set + bounded slow set, 2 processes)
#   make docs   - create .venv, install, build the documentation site -> docs/_build/html/index.html
# Other tiers:
#   make test-fast   - the default set only (every capability, a few minutes)
#   make check-long  - the long statistical checks (self-checks over many datasets, leave-one-law-out, recovery
#                      table; not in CI) and the diagnosis page's generated tables;
#                      each writes its table under results/long/ with the command, seed and code version
#   make bench       - speed figures (medians, p99, against peers): timing lives there, never in a test
#   make peer   - create .venv-peer (project + acados, apart from .venv), run benchmarks/peer_acados.py
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin
STAMP   = $(VENV)/.installed
# The acados peer lives in its own environment: its wheel (comma-deps-acados) overwrites CasADi's core
# library inside the casadi package with its own build, after which sqpmethod (diagnose, calibrate) is gone.
PEER_VENV  ?= .venv-peer
PEER_BIN    = $(PEER_VENV)/bin
PEER_STAMP  = $(PEER_VENV)/.installed
PEER_ARGS  ?=

# Test workers (pytest-xdist); CI has 2 cores. `make test XDIST=` runs in one process.
XDIST  ?= -n 2
PYTEST  = $(BIN)/python -m pytest

.PHONY: run test test-fast test-slow check-long lint bench docs peer clean-venv

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,campaign,bench,docs]'
	touch $(STAMP)

RUN_OUT ?= results

run: $(STAMP)
	$(BIN)/python -m maglev_ocp.main_job --out $(RUN_OUT)

test: $(STAMP) lint
	$(PYTEST) -q $(XDIST) -m "not long" --durations=25

test-fast: $(STAMP)
	$(PYTEST) -q $(XDIST) --durations=10

test-slow: $(STAMP)
	$(PYTEST) -q $(XDIST) -m "slow" --durations=10

# The tables are written before the assertions; the diagnosis page's confusion matrices, per-effect rows,
# timings and targets are then regenerated from them (benchmarks/diagnosis_page.py), pass or fail.
check-long: $(STAMP)
	$(PYTEST) -q -m long --durations=0; status=$$?; $(BIN)/python -m benchmarks.diagnosis_page; exit $$status

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/lint-imports

bench: $(STAMP)
	$(BIN)/python -m benchmarks.run_all

# Warnings are errors; the gallery's examples (examples/) run during the build and must not fail.
docs: $(STAMP)
	MPLBACKEND=Agg $(BIN)/sphinx-build -W --keep-going -b html docs docs/_build/html

$(PEER_STAMP): pyproject.toml
	$(PYTHON) -m venv $(PEER_VENV)
	$(PEER_BIN)/python -m pip install --quiet --upgrade pip
	$(PEER_BIN)/python -m pip install --quiet -e .
	$(PEER_BIN)/python -m pip install --quiet comma-deps-acados
	touch $(PEER_STAMP)

peer: $(PEER_STAMP)
	$(PEER_BIN)/python benchmarks/peer_acados.py $(PEER_ARGS)

clean-venv:
	rm -rf $(VENV)

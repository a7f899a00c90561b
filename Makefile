# Two commands set up a fresh machine (only Python needed):
#   make run    - create .venv, install, run the headline job (writes build/results/, untracked: git status stays
#                 clean; `make results` regenerates the committed snapshot results/ instead)
#   make test   - create .venv, install, run the test suite (not-slow, then slow)
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

.PHONY: run results test test-fast test-slow selfcheck lint bench peer clean-venv

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,campaign,bench]'
	touch $(STAMP)

RUN_OUT ?= build/results

run: $(STAMP)
	$(BIN)/python -m maglev_ocp.main_job --out $(RUN_OUT)

# The committed snapshot results/ (timings and dates change it on every run: commit it on purpose).
results: $(STAMP)
	$(BIN)/python -m maglev_ocp.main_job --out results

test: $(STAMP) lint
	$(BIN)/python -m pytest -q
	$(BIN)/python -m pytest -q -m "slow and not selfcheck"

test-fast: $(STAMP)
	$(BIN)/python -m pytest -q

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m "slow and not selfcheck"

selfcheck: $(STAMP)
	$(BIN)/python -m pytest -q -m selfcheck

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/lint-imports

bench: $(STAMP)
	$(BIN)/python -m benchmarks.run_all

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

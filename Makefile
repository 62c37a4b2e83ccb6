# Two entry points for a fresh clone: `make demo` and `make test` (each sets everything up).
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

# Small GPs and physics run far faster single-threaded on 2 cores (see field facts).
export OMP_NUM_THREADS ?= 1
export OPENBLAS_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1
export PYTHONDONTWRITEBYTECODE := 1

.PHONY: setup demo test test-all lint bench clean

setup: $(STAMP)

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --disable-pip-version-check -c constraints.txt -e '.[dev]'
	touch $(STAMP)

demo: setup
	$(BIN)/ltamp solve problems/examples/tamp2d_blocked.yaml

test: setup
	$(BIN)/ruff check ltamp_cli tests bench
	$(BIN)/python -m pytest -q tests

lint: setup
	$(BIN)/ruff check ltamp_cli tests bench

bench: setup
	$(BIN)/python bench/planner.py

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache

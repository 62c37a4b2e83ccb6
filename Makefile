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
	$(BIN)/pip install --quiet --disable-pip-version-check -c constraints.txt -e '.[dev,pybullet,sapien,fd,ray,gpytorch]'
	touch $(STAMP)

# The coffee task of the 2D kitchen: plan with the shipped pour/scoop models, execute the plan
# in Box2D, check the goal physically and write an animation.
demo: setup
	mkdir -p out
	$(BIN)/ltamp solve problems/kitchen2d/coffee.yaml --backend box2d --seed 1 --render out/coffee.gif

test: setup
	$(BIN)/ruff check ltamp_cli tests bench
	$(BIN)/python -m pytest -q -n 2 --dist loadscope tests

lint: setup
	$(BIN)/ruff check ltamp_cli tests bench

bench: setup
	$(BIN)/python bench/planner.py

# The seed paper's experiments at reduced repetitions (<= 30 min on 2 cores): JSON + PNG in
# docs/results/quick, report in docs/RESULTS.md. `python -m bench.paper --full` for all.
.PHONY: paper-quick
paper-quick: setup
	$(BIN)/python -m bench.paper --quick

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache

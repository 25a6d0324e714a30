# odolab: `make demo` runs the whole lab on the virtual Jaguar; `make test` runs the test suite.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast test-determinism lint typecheck bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e '.[all,dev]'
	@touch $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(BIN)/odolab demo

# two test processes more than the cores: the real-time robot runs and the browsers wait more than
# they compute, and the extra processes fill that wait (on 2 cores: 3 workers 8 min 56 s against
# 2 workers' 10 min 13 s; 4 workers 0.526 s of wall a second of CPU against 3 workers' 0.541-0.557,
# three runs each way alternated: docs/testing.md)
WORKERS ?= $(shell $(PYTHON) -c "import os; print(len(os.sched_getaffinity(0)) + 2)" 2>/dev/null || echo 4)

# PYTHONDONTWRITEBYTECODE is emptied for the tests: where the environment sets it (this project's
# machines do), every test process and every `odolab` a test starts compiled odolab's source
# again, and pytest rewrote every test module's asserts again in each worker (a worker's collection
# 16 s of CPU against 8 s with the cache; .gitignore leaves __pycache__ out)
TESTENV := MPLBACKEND=Agg OPENBLAS_NUM_THREADS=1 PYTHONDONTWRITEBYTECODE=

# every test, in a new random order each run (pytest-randomly prints the seed: rerun an order with
# `-p randomly --randomly-seed=N`), then the 20 slowest; docs/testing.md has the timings. An idle
# worker takes tests queued for a busy one (`--dist worksteal`): with xdist's default `load`, the
# last worker ran alone for 8-78 s after the others had finished (three fresh-clone runs)
DIST := --dist worksteal
test: $(STAMP)
	$(TESTENV) $(BIN)/python -m pytest -n $(WORKERS) $(DIST) -q --durations=20

# while developing: leaves out the tests marked slow (documented commands, real-time robot runs,
# the demos in chromium, the independent simulators); `make test` and CI run everything
test-fast: $(STAMP)
	$(TESTENV) $(BIN)/python -m pytest -n $(WORKERS) $(DIST) -q -m "not slow"

# the statistical tests twice, in two random orders, two hash seeds and two xdist distributions:
# every asserted number must come out the same (tests/determinism.py)
test-determinism: $(STAMP)
	$(TESTENV) $(BIN)/python tests/determinism.py

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks
	$(BIN)/mypy
	$(BIN)/lint-imports

typecheck: $(STAMP)
	$(BIN)/mypy

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_odometry.py

clean:
	rm -rf $(VENV) build dist src/*.egg-info .pytest_cache .mypy_cache .ruff_cache

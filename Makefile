# The two README commands: `make run` (main job on the simulated bench, writes the PDF report)
# and `make test` (the project's tests). Both create their own virtual environment.
PYTHON ?= python3
VENV := .venv
STAMP := $(VENV)/.installed-stamp
BIN := $(VENV)/bin
# pytest-xdist workers for `make test` (tests/conftest.py schedules them: shared fixtures built once)
TEST_WORKERS ?= 2

.PHONY: run test bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	$(BIN)/python -m hil.warmup
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/hil run

test: $(STAMP)
	.ci/setup-motulator
	$(BIN)/python -m pytest -n $(TEST_WORKERS)

bench: $(STAMP)
	$(BIN)/python -m benchmarks

clean:
	rm -rf $(VENV) .venv-motulator build *.egg-info

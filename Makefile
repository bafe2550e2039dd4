# Two entry points for a fresh machine with only Python >= 3.11:
#   make demo   -> builds .venv, installs mocapkit, runs `mocapkit demo`
#   make test   -> builds .venv with test extras, runs ruff and the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install -q -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/mocapkit demo --out demo_out

lint: $(STAMP)
	$(BIN)/ruff check src tests bench

test: $(STAMP) lint
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/python bench/bench_io.py

clean:
	rm -rf $(VENV) demo_out .pytest_cache .hypothesis

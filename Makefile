# trebuchet: set-up, demo, tests, benchmarks. Everything installs into .venv.
PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV := .venv
BIN := $(VENV)/bin

.PHONY: install install-test demo test lint bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

# The simulator is compiled once (numba, ~30 s) and cached beside its sources.
$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e .
	$(BIN)/python -m trebuchet.warm_up
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e '.[test]'
	$(BIN)/python -m trebuchet.warm_up
	touch $(VENV)/.installed $@

install: $(VENV)/.installed

install-test: $(VENV)/.installed-test

DEMO_LOG := data_samples/horsdal_240fps.csv
DEMO_SCENE := data_samples/horsdal_large.toml

demo: install
	$(BIN)/trebuchet compare $(DEMO_LOG) --scene $(DEMO_SCENE) -o demo_report
	@echo "Report: $(CURDIR)/demo_report/index.html"

test: install-test
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q

bench: install-test
	$(BIN)/python -m bench
	$(BIN)/python docs/update_docs.py

clean:
	rm -rf $(VENV) build *.egg-info

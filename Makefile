# trebuchet: set-up, demo, tests, benchmarks. Everything installs into .venv.
PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV := .venv
BIN := $(VENV)/bin

.PHONY: install install-test browser demo test lint bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

# The simulator's C engine (generated from the model's formulas, gcc) and the numba kernels are
# compiled once (about 40 s) and cached beside their sources; a changed source rebuilds them.
$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e .
	$(BIN)/python -m trebuchet.warm_up
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e '.[test]'
	$(BIN)/python -m trebuchet.warm_up
	@$(MAKE) --no-print-directory browser
	touch $(VENV)/.installed $@

# The report's browser test (tests/test_report_browser.py) runs Debian's headless chromium.
# Installed here when missing and when run as root; else the test skips and says why.
browser:
	@if command -v chromium >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  echo "installing chromium for the report's browser test"; \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium >/dev/null 2>&1 || \
	  { apt-get update -q >/dev/null 2>&1 && \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium >/dev/null 2>&1; } || \
	  echo "chromium could not be installed: the browser test will be skipped"; \
	else echo "no chromium (install Debian's chromium as root): the browser test will be skipped"; fi

install: $(VENV)/.installed

install-test: $(VENV)/.installed-test

DEMO_LOG := data_samples/horsdal_240fps.csv
DEMO_SCENE := data_samples/horsdal_large.toml
# A shot rendered and tracked by the video bench (DeepLabCut pixels, a camera pitched up 4°)
# with the user's own calibration of it (six known points of the engine's plane).
DEMO_VIDEO := data_samples/video_paper_dlc.csv
DEMO_VIDEO_SCENE := data_samples/video_paper.toml
DEMO_VIDEO_CALIBRATION := data_samples/video_paper_points.csv

demo: install
	$(BIN)/trebuchet compare $(DEMO_LOG) --scene $(DEMO_SCENE) -o demo_report
	$(BIN)/trebuchet forces $(DEMO_VIDEO) --scene $(DEMO_VIDEO_SCENE) --fps 240 \
	    --calibration $(DEMO_VIDEO_CALIBRATION) -o demo_report/video_loads.csv
	@echo "Report: $(CURDIR)/demo_report/index.html; loads of the tracked video: $(CURDIR)/demo_report/video_loads.csv"

test: install-test
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q

bench: install-test
	$(BIN)/python -m bench
	$(BIN)/python docs/update_docs.py

clean:
	rm -rf $(VENV) build *.egg-info

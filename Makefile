# dempath: two commands for users, `make demo` and `make test`; both set up .venv on first use.
SHELL := /bin/bash
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
BIN := $(VENV)/bin
PKGS := dempath dempath_calib dempath_recon dempath_sim dempath_compare dempath_twin dempath_diagnose dempath_bringup
MSG_FILES := $(wildcard src/dempath_msgs/msg/*.msg) src/dempath_msgs/CMakeLists.txt src/dempath_msgs/pyproject.toml
PKG_FILES := $(foreach p,$(PKGS),src/$(p)/setup.py src/$(p)/setup.cfg)

# ROS discovery stays on this machine unless the user deploys across machines and overrides it.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export AMENT_PREFIX_PATH ?= $(abspath $(VENV))

.PHONY: demo test lint bench figures setup clean
demo: $(VENV)/.installed
	$(BIN)/dempath demo --data bags

test: $(VENV)/.installed
	$(BIN)/python -m pytest -n 2 --durations=15

lint: $(VENV)/.installed
	$(BIN)/ruff check src tests bench
	$(BIN)/mypy

bench: $(VENV)/.installed
	for b in $(filter-out bench/figures.py,$(wildcard bench/*.py)); do $(BIN)/python $$b || exit 1; done

# Every figure the docs show, regenerated from the current code (bench/figures.py; --slow: piles)
figures: $(VENV)/.installed
	nice -n 10 $(BIN)/python bench/figures.py

setup: $(VENV)/.installed

# Runtime (requirements.txt), the optional MLP (requirements-mlp.txt: torch, which tests and the
# MLP's bench need), tests and lint (requirements-dev.txt), the msgs build (requirements-build.txt)
REQS := requirements.txt requirements-mlp.txt requirements-dev.txt requirements-build.txt

$(VENV)/.deps: $(REQS) constraints.txt
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check \
	  $(foreach r,$(REQS),-r $(r)) -c constraints.txt
	touch $@

$(VENV)/.msgs: $(VENV)/.deps $(MSG_FILES)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check --no-build-isolation --no-deps ./src/dempath_msgs
	touch $@

$(VENV)/.installed: $(VENV)/.msgs $(PKG_FILES)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check --no-build-isolation --no-deps \
	  $(foreach p,$(PKGS),-e src/$(p))
	touch $@

clean:
	rm -rf $(VENV) build src/dempath_msgs/build

# Two commands set everything up on a fresh machine:
#   make demo   # create .venv, build with colcon, run the paper's example through both nodes
#   make test   # same set-up, then colcon test + colcon test-result (fails on any failure)
# With an apt-installed ROS 2 Jazzy already sourced (ROS_DISTRO=jazzy) the
# system python3 and colcon are used instead of .venv.

SHELL := /bin/bash
.SHELLFLAGS := -o pipefail -c
.DEFAULT_GOAL := help

# DDS traffic stays on this machine for every target (no multicast on the LAN).
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST

VENV := .venv
ifeq ($(ROS_DISTRO),jazzy)
BIN :=
PYTHON := python3
COLCON := colcon
ENV_STAMP :=
SKIPS :=
else
BIN := $(abspath $(VENV))/bin/
PYTHON := $(BIN)python
COLCON := $(BIN)colcon
ENV_STAMP := $(VENV)/.installed
# Every test's packages are pinned in .venv: a skipped test means one is missing.
SKIPS := --skips-fail
# The Jazzy wheels and the pins are for Python 3.11 (Ubuntu 24.04's 3.12 breaks the
# pinned setuptools in the interfaces' build): python3.11 where there is one.
PYTHON311 := $(shell command -v python3.11 || command -v python3)
# The Jazzy wheels install their CMake configs and ament index in the venv:
# CMake and the rosidl generators of splines445_interfaces find them there.
export CMAKE_PREFIX_PATH := $(abspath $(VENV))
export AMENT_PREFIX_PATH := $(abspath $(VENV))
endif

# The repository's root is splines445_ros; colcon does not crawl into a package,
# so the interface package inside it is named too.
COLCON_PATHS := --base-paths . splines445_interfaces --build-base build --install-base install
SOURCE_INSTALL := source install/setup.bash
OUT ?= out

.PHONY: help env build test demo bench lint clean

LINTED := splines445_ros test scripts benchmarks setup.py

help:
	@echo "make demo   set up, build, run the paper's example through both nodes"
	@echo "make test   set up, build, colcon test, colcon test-result --verbose"
	@echo "make bench  planning time and optimal durations against scipy and TOPP-RA,"
	@echo "            tracking and torque of every method on the dynamic arm,"
	@echo "            replanning from moving states, near-duplicate waypoints,"
	@echo "            message size and publishing time of output: sampled against"
	@echo "            output: knots, UR5 and Panda seams at 1 mm / 1 deg"
	@echo "make lint   ament_flake8 and ament_pep257 on the sources"
	@echo "make clean  remove build products (keeps .venv)"

env: $(ENV_STAMP)
ifneq ($(ENV_STAMP),)
	@# Again every time (about a second when nothing is missing): a package removed
	@# from .venv since it was set up is installed again, not skipped by its tests.
	$(VENV)/bin/pip install --disable-pip-version-check -q -r requirements.txt
endif

$(VENV)/.installed: requirements.txt
	@$(PYTHON311) -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' || { \
	    echo "make: .venv needs Python 3.11 (python3.11, or python3 being 3.11): the"; \
	    echo "pinned ROS 2 Jazzy wheels are for it. Found: $(PYTHON311)"; exit 1; }
	$(PYTHON311) -m venv $(VENV)
	$(VENV)/bin/pip install --disable-pip-version-check -q pip==26.3
	$(VENV)/bin/pip install --disable-pip-version-check -q -r requirements.txt
	touch $@

# setuptools copies modules into build/ and install/ but never removes one: a module
# moved or deleted since the last build would stay importable (old code) beside the new.
# So the Python package is copied afresh each time (a second or two); the interfaces stay.
build: env
	rm -rf build/splines445_ros/build install/splines445_ros/lib/python*/site-packages/splines445_ros
	@# setuptools does not byte-compile here: a syntax error would only show where imported.
	$(PYTHON) -m compileall -q splines445_ros benchmarks scripts
	$(COLCON) build $(COLCON_PATHS) --event-handlers console_cohesion- summary+

test: build
	@rm -f build/test_result.txt build/test_summary.txt; rc=0; \
	$(COLCON) test $(COLCON_PATHS) --test-result-base build/test_results \
	    --event-handlers console_direct+ summary+ || rc=$$?; \
	$(COLCON) test-result --test-result-base build/test_results --verbose \
	    | tee build/test_result.txt || rc=$$?; \
	$(PYTHON) scripts/test_summary.py build/test_result.txt $(SKIPS) | tee build/test_summary.txt \
	    || rc=$$?; \
	exit $$rc

demo: build
	$(SOURCE_INSTALL) && install/splines445_ros/lib/splines445_ros/demo --out $(OUT)

bench: build
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_planning.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_optimal.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_inner_knots.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_arm_moves.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_vibration_residual.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_shaking_bound.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_smooth_profile.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_smoothness.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_replanning.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_near_duplicates.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_position_limits.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_output.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_robot_seam.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_tool_lines.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_torque.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_torque_arm.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_jerk_profile.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_time_budget.py
	$(SOURCE_INSTALL) && $(PYTHON) benchmarks/bench_tool_jerk.py

lint: env
	$(BIN)ament_flake8 $(LINTED)
	$(BIN)ament_pep257 $(LINTED)

clean:
	rm -rf build install log $(OUT)

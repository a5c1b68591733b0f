# Two entry points, both idempotent, no activation needed:
#   make demo   -> create .venv, install, run the maritime scenario with recording, print a summary + picture
#   make test   -> create .venv, install, ruff check, the whole pytest suite
VENV    := .venv
PY      := $(VENV)/bin/python3
PIP     := $(PY) -m pip -q --disable-pip-version-check
PKGS    := src/track_core src/track_msgs_py src/track_nodes src/track_experiments
export AMENT_PREFIX_PATH := $(CURDIR)/$(VENV)

.PHONY: install demo test lint clean

$(VENV)/.deps-stamp: requirements.txt constraints.txt
	test -x $(PY) || python3 -m venv $(VENV)
	$(PIP) install -r requirements.txt -c constraints.txt
	touch $@

# Interface packages we build ourselves (tf2_msgs: not on PyPI), into the venv prefix: rebuilt when
# the ROS wheel pins (via the deps stamp), the build-only pins or the interface files change.
# tools/build_interfaces.py patches the wheels' cmake include paths first, every time (docs/DESIGN.md, "Building tf2_msgs").
INTERFACE_FILES := $(shell find interfaces -type f)
$(VENV)/.interfaces-stamp: $(VENV)/.deps-stamp requirements-interfaces.txt constraints.txt \
		tools/build_interfaces.py $(INTERFACE_FILES)
	$(PIP) install -r requirements-interfaces.txt -c constraints.txt
	$(PY) tools/build_interfaces.py
	touch $@

# Non-editable install: editable installs carry no data_files, so `ros2 run` would not see them.
# Stale build/ trees leak old modules into new wheels, so remove them first.
install: $(VENV)/.deps-stamp $(VENV)/.interfaces-stamp
	rm -rf $(addsuffix /build,$(PKGS)) $(addsuffix /*.egg-info,$(PKGS))
	# One package at a time, in layer order: uninstalling an older package never removes a script a newer one installed.
	for pkg in $(PKGS); do $(PIP) install --no-deps --no-build-isolation --force-reinstall $$pkg || exit 1; done
	rm -rf $(addsuffix /build,$(PKGS)) $(addsuffix /*.egg-info,$(PKGS))

demo: install
	$(PY) -m track_nodes.launch maritime --record

lint: $(VENV)/.deps-stamp
	$(VENV)/bin/ruff check .

# Two workers (this machine has 2 cores; most tests wait on DDS, subprocesses or a paced /clock):
# 9.6 min serial against 5.6 min. --dist loadfile keeps a file's tests (and its module fixtures)
# on one worker; test/conftest.py gives each worker its own slice of ROS domains.
test: install lint
	$(PY) -m pytest -n 2 --dist loadfile

clean:   # also a colcon build's build/ install/ log/ (README, "colcon workspace"); build/ holds build/interfaces
	rm -rf $(VENV) $(addsuffix /build,$(PKGS)) $(addsuffix /*.egg-info,$(PKGS)) build install log

# fingertip: one entry point for users, developers and CI.
#   make demo      the whole chain on a virtual fingertip (no hardware): live stream, PNG
#   make setup     Debian packages (when missing) and .venv with pinned Python packages
#   make test      set-up, native C++ tests, firmware build, every pytest suite
#   make firmware  the Uno firmware with avr-gcc (ELF + HEX, sizes checked)
#   make sim       the simavr harness that runs that firmware with simulated HX711s
#   make bench     benchmarks -> docs/benchmarks.md and docs/benchmarks.json
# Run `make help` for the rest.

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help

PYTHON ?= python3
VENV := .venv
VPY := $(VENV)/bin/python
STAMPS := .stamps

# Debian packages, grouped by what needs them (../shared/NOTES.md has the details).
APT_BUILD := make g++ pkg-config
APT_PYTHON := python3 python3-venv
APT_FIRMWARE := gcc-avr avr-libc arduino-core-avr binutils-avr avrdude
APT_NATIVE_TESTS := doctest-dev nlohmann-json3-dev
APT_SIM := simavr libsimavr-dev libelf-dev
# PortAudio for sounddevice; a private PulseAudio server with a null sink for audio tests.
APT_AUDIO := libportaudio2 pulseaudio pulseaudio-utils libasound2-plugins
APT_PACKAGES := $(APT_BUILD) $(APT_PYTHON) $(APT_FIRMWARE) $(APT_NATIVE_TESTS) $(APT_SIM) \
                $(APT_AUDIO)

PYTEST_ARGS ?=

.PHONY: help setup system-packages venv venv-fab test test-native test-python lint firmware sim demo \
        bench vectors clean distclean

help:
	@sed -n '2,9p' Makefile | sed 's/^# *//'
	@echo "  make test-native  only the C++ codec tests (sanitizers)"
	@echo "  make test-python  only pytest (PYTEST_ARGS=... to pass options)"
	@echo "  make lint         ruff on host/, tests/, pcb/ and mechanical/"
	@echo "  make pcb          KiCad checks and fabrication outputs (pcb/pcb.mk)"
	@echo "  make cad          STL, STEP and PNG of every part into build/cad (CAD_ARGS=--set ...)"
	@echo "  make vectors      regenerate tests/vectors/protocol_v1.json"
	@echo "  make clean        remove build outputs (keeps .venv)"

# --- set-up ---------------------------------------------------------------------------------

setup: system-packages venv

system-packages:
	@tools/ensure-packages.sh $(APT_PACKAGES)

venv: $(STAMPS)/venv

$(STAMPS)/venv: pyproject.toml requirements/dev.txt | system-packages
	@mkdir -p $(STAMPS)
	@test -x $(VPY) || $(PYTHON) -m venv $(VENV)
	$(VPY) -m pip install -q --disable-pip-version-check -c requirements/dev.txt \
	    pip setuptools wheel
	$(VPY) -m pip install -q --disable-pip-version-check -c requirements/dev.txt \
	    --no-build-isolation -e ".[dev]"
	@touch $@

# The CAD and PCB extras (CadQuery pulls in VTK, about 1.8 GB): only for `make cad`, `make pcb`
# and the tests, so that `make demo` stays small.
venv-fab: $(STAMPS)/venv-fab

$(STAMPS)/venv-fab: $(STAMPS)/venv
	$(VPY) -m pip install -q --disable-pip-version-check -c requirements/dev.txt \
	    --no-build-isolation -e ".[dev,cad,pcb]"
	@touch $@

# Boards (pcb/) and parametric CAD (mechanical/): their targets live beside them.
-include pcb/pcb.mk
-include mechanical/cad.mk

# --- build and test -------------------------------------------------------------------------

test: setup
	$(MAKE) --no-print-directory test-native
	$(MAKE) --no-print-directory firmware
	$(MAKE) --no-print-directory sim
	$(MAKE) --no-print-directory -C firmware/sim selftest
	$(MAKE) --no-print-directory lint
	$(MAKE) --no-print-directory pcb-check
	$(MAKE) --no-print-directory test-python

test-native: system-packages
	$(MAKE) --no-print-directory -C firmware test-native

firmware: system-packages
	$(MAKE) --no-print-directory -C firmware all

# make flash PORT=/dev/ttyACM0 [CHANNELS=4|16]: build, then upload with avrdude.
.PHONY: flash
flash:
	@test -n "$(PORT)" || { echo "usage: make flash PORT=/dev/ttyACM0 [CHANNELS=4|16]" >&2; exit 2; }
	$(MAKE) --no-print-directory firmware venv
	$(VENV)/bin/fingertip flash --port "$(PORT)" --channels "$(or $(CHANNELS),4)"

# The firmware-in-the-loop harness: the real ELF in simavr with simulated HX711s on a pty.
sim: system-packages
	$(MAKE) --no-print-directory -C firmware/sim

lint: venv
	$(VENV)/bin/ruff check host tests pcb mechanical

# pytest exits 5 when it collected nothing: that must fail, never pass as "green".
test-python: venv venv-fab pcb-tools
	@rc=0; $(VPY) -m pytest $(PYTEST_ARGS) || rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "pytest collected no tests: failing" >&2; exit 1; fi; \
	exit $$rc

# The virtual fingertip end to end: physics -> the firmware in simavr -> bridge -> events.
demo: setup
	$(MAKE) --no-print-directory firmware sim
	$(VPY) -m fingertip.cli demo --out demo-output
	$(VPY) -m fingertip.cli experiment pinch --trials 3 --seed 0

bench: setup
	$(MAKE) --no-print-directory -C firmware bauds
	$(VPY) tests/bench/run.py

vectors: venv
	$(VPY) tests/vectors/generate.py

clean:
	rm -rf build firmware/build firmware/sim/build .pytest_cache

distclean: clean
	rm -rf $(VENV) $(STAMPS)

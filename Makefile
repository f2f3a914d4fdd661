# fingertip: one entry point for users, developers and CI.
#   make demo      the whole chain on a virtual fingertip (no hardware): live stream, PNG
#   make setup     Debian packages (when missing) and .venv with pinned Python packages
#   make test      set-up, native C++ tests, firmware build, every pytest suite
#   make firmware  the Uno firmware with avr-gcc (ELF + HEX, sizes checked)
#   make sim       the simavr harness that runs that firmware with simulated HX711s
#   make hostlib   the firmware's device logic as a host library (the virtual fingertip)
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
# clang with libFuzzer and the sanitizer runtimes, for the firmware fuzzers (firmware/fuzz).
APT_FUZZ := clang libclang-rt-14-dev
# Mesa's EGL for MuJoCo's headless rendering (MUJOCO_GL=egl, `--render`).
APT_RENDER := libegl1 libegl-mesa0 libgl1-mesa-dri
APT_PACKAGES := $(APT_BUILD) $(APT_PYTHON) $(APT_FIRMWARE) $(APT_NATIVE_TESTS) $(APT_SIM) \
                $(APT_AUDIO) $(APT_FUZZ) $(APT_RENDER)

PYTEST_ARGS ?=

.PHONY: help setup system-packages venv venv-fab test test-native test-python lint firmware sim demo \
        bench drumkits vectors clean distclean hostlib

help:
	@sed -n '2,10p' Makefile | sed 's/^# *//'
	@echo "  make test-native  only the C++ codec tests (sanitizers)"
	@echo "  make drumkits     fetch the pinned hydrogen-drumkits (GPL kits) into build/ for make bench"
	@echo "  make soak         the soak test (SOAK_MINUTES=30): devices killed, memory, files"
	@echo "  make fuzz         libFuzzer on the firmware's decoder and receiver (FUZZ_SECONDS=600 each)"
	@echo "  make test-python  only pytest (PYTEST_ARGS=... to pass options, PYTEST_WORKERS=N)"
	@echo "  make lint         ruff on host/, tests/, studies/, pcb/ and mechanical/"
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

# The C++ builds compile on every core (NPROC jobs): the same checks, a shorter wait. Each
# step prints its wall time at the end ("make test: STEP took N s"), so a slow one shows.
NPROC := $(shell nproc 2>/dev/null || echo 2)
STEP = @t0=$$(date +%s); $(MAKE) --no-print-directory $(2); \
	echo "make test: $(1) took $$(( $$(date +%s) - t0 )) s"
test: setup
	$(call STEP,test-native,-j$(NPROC) test-native)
	$(call STEP,test-fuzz,-j$(NPROC) test-fuzz)
	$(call STEP,firmware,-j$(NPROC) firmware)
	$(call STEP,sim,-j$(NPROC) sim)
	$(call STEP,hostlib,-j$(NPROC) hostlib)
	$(call STEP,selftest,-C firmware/sim selftest)
	$(call STEP,lint,lint)
	$(call STEP,pcb-check,pcb-check)
	$(call STEP,test-python,test-python)

test-native: system-packages
	$(MAKE) --no-print-directory -C firmware test-native

firmware: system-packages
	$(MAKE) --no-print-directory -C firmware all

# libFuzzer on the firmware's COBS decoder and command receiver, seeded from the shared
# vectors: 30 s per target in `make test`, FUZZ_SECONDS per target in `make fuzz`; the two
# targets run side by side, one core each (30 s of wall time on two cores).
FUZZ_SECONDS ?= 600
.PHONY: test-fuzz fuzz
test-fuzz: system-packages
	$(MAKE) --no-print-directory -C firmware/fuzz run SECONDS=30

fuzz: system-packages
	$(MAKE) --no-print-directory -C firmware/fuzz run SECONDS=$(FUZZ_SECONDS)

# make flash PORT=/dev/ttyACM0 [CHANNELS=4|16]: build, then upload with avrdude.
.PHONY: flash
flash:
	@test -n "$(PORT)" || { echo "usage: make flash PORT=/dev/ttyACM0 [CHANNELS=4|16]" >&2; exit 2; }
	$(MAKE) --no-print-directory firmware venv
	$(VENV)/bin/fingertip flash --port "$(PORT)" --channels "$(or $(CHANNELS),4)"

# The virtual fingertip runs the firmware's own C++ through this library; there is no Python
# copy to fall back on, so a failed build stops here.
hostlib: system-packages
	$(MAKE) --no-print-directory -C firmware hostlib

# The firmware-in-the-loop harness: the real ELF in simavr with simulated HX711s on a pty.
sim: system-packages
	$(MAKE) --no-print-directory -C firmware/sim

lint: venv
	$(VENV)/bin/ruff check host tests pcb mechanical studies

# pytest in two passes at the same time (tools/run-pytest.sh says how): the tests marked
# `realtime` (they assert on wall-clock time) one at a time at normal priority, beside the
# others spread over PYTEST_WORKERS processes under nice (pytest-xdist, test by test; the tests
# of a module that share a module fixture stay together on one worker, which builds it once:
# tests/conftest.py). PYTEST_ARGS goes to both; when neither collects a test, that fails.
PYTEST_WORKERS ?= 3
# One BLAS/OpenMP thread a test process: three workers on two cores, each with a pool of its
# own, would oversubscribe the cores (OpenBLAS spins while it waits).
test-python: export OMP_NUM_THREADS = 1
test-python: export OPENBLAS_NUM_THREADS = 1
test-python: export MKL_NUM_THREADS = 1
test-python: venv venv-fab pcb-tools hostlib
	@tools/run-pytest.sh $(VPY) $(PYTEST_WORKERS) $(PYTEST_ARGS)

# The virtual fingertip end to end: physics -> the firmware in simavr -> bridge -> events.
demo: setup
	$(MAKE) --no-print-directory firmware sim hostlib
	$(VPY) -m fingertip.cli demo --out demo-output
	$(VPY) -m fingertip.cli experiment pinch --trials 3 --seed 0

bench: setup hostlib drumkits
	$(MAKE) --no-print-directory -C firmware bauds
	$(VPY) tests/bench/run.py

# Real hits for the vibration bench's public-set figures: Debian's hydrogen-drumkits (GPL kits),
# pinned, downloaded and unpacked into build/drumkits (not installed, never shipped). Only
# `bench` needs it, never `test`; when it cannot be fetched it warns in one line and the bench
# skips those figures. FINGERTIP_DRUMKITS=FOLDER makes the bench read another copy.
drumkits:
	@bash tools/fetch-drumkits.sh build/drumkits

# Hours, not seconds: four virtual fingertips with audio, forces, events and a recording,
# devices killed and restarted; figures soak_* into docs/benchmarks.json. Not in `test`.
SOAK_MINUTES ?= 30
.PHONY: soak
soak: setup
	$(VPY) tests/bench/bench_soak.py --minutes $(SOAK_MINUTES)

vectors: venv
	$(VPY) tests/vectors/generate.py

clean:
	rm -rf build firmware/build firmware/sim/build .pytest_cache

distclean: clean
	rm -rf $(VENV) $(STAMPS)

# yamor — the developer entry points. `make demo` and `make test` each do all
# set-up themselves on a fresh machine.
PRESET ?= release
BUILD_DIR := build/$(PRESET)
FUZZ_TIME ?= 300
FUZZ_SMOKE_TIME ?= 10
SOAK_TIME ?= 600
JOBS ?= $(shell nproc)
PY := .venv/bin/python

.PHONY: all deps configure build test test-unit test-py fuzz fuzz-build fuzz-smoke bench demo clean asan tsan soak

all: build

deps:
	@tools/deps/install.sh

configure: deps
	@cmake --preset $(PRESET) >/dev/null

build: configure
	@cmake --build --preset $(PRESET) -j $(JOBS)

test-unit: build
	@ctest --preset $(PRESET) -j $(JOBS)

test-py: deps
	@if [ -d tests/python ]; then $(PY) -m pytest -q tests/python; fi

test: test-unit test-py fuzz-smoke
	@echo "make test: all suites passed"

# AddressSanitizer + UBSan over the unit and end-to-end suites. The asan test
# preset sets ASAN_OPTIONS=detect_leaks=0:abort_on_error=1: LeakSanitizer's
# exit check deadlocked against a report still being written by another
# thread (issue 17), so a failure hung instead of failing; abort_on_error
# ends the process at the first report. Every test also has a ctest TIMEOUT
# (tests/CMakeLists.txt, times 4 under asan), so a hang fails in minutes.
asan:
	@$(MAKE) test-unit PRESET=asan

# ThreadSanitizer over the unit and end-to-end suites (TSAN_OPTIONS in the
# tsan test preset: halt at the first report; tools/tsan/suppressions.txt
# holds third-party suppressions only, each with its reason). The tsan test
# preset leaves out the long single-threaded physics shards
# (NeverDiverges|HundredTimes|LoopsClose: one thread, nothing to race; about
# an hour of CPU under TSan); the release and asan runs keep them.
tsan:
	@$(MAKE) test-unit PRESET=tsan

fuzz-build: deps
	@cmake --preset fuzz >/dev/null
	@cmake --build --preset fuzz -j $(JOBS)

# Each fuzzer runs FUZZ_SMOKE_TIME seconds from its seed corpus.
fuzz-smoke: fuzz-build
	@tools/fuzz/run.sh build/fuzz $(FUZZ_SMOKE_TIME)

# As long as asked: make fuzz FUZZ_TIME=3600
fuzz: fuzz-build
	@tools/fuzz/run.sh build/fuzz $(FUZZ_TIME)

# The daemon soak (issue 17): one asan yamord, 64 clients, SOAK_TIME seconds
# (.venv/bin/yamor-soak --help; SOAK_ARGS adds options). Builds only yamord.
soak: deps
	@cmake --preset asan >/dev/null
	@cmake --build --preset asan -j $(JOBS) --target yamord
	@$(PY) -m yamor.tools.soak --yamord build/asan/host/yamord --duration $(SOAK_TIME) $(SOAK_ARGS)

bench: build
	@tools/bench/run.sh $(BUILD_DIR)

demo: build
	@tools/demo.sh $(BUILD_DIR)

clean:
	rm -rf build

# Thin wrapper over CMake: `make` builds, `make run` runs `gaussvid reconstruct` on the default
# scene (scripts/demo.sh), `make test` runs every test.
JOBS ?= $(shell nproc)
BUILD := build
ASAN_BUILD := build-asan
FUZZ_BUILD := build-fuzz
# Seconds per libFuzzer harness for `make fuzz` (`make test` runs each for 10, with a fixed
# seed); FUZZ_SEED fixes libFuzzer's seed when set.
FUZZ_SECONDS ?= 60
FUZZ_SEED ?=
DEMO := demo

.PHONY: all setup build run install test test-asan fuzz bench clean

all: build

setup:
	@bash scripts/setup.sh

build: setup
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release >/dev/null
	@cmake --build $(BUILD) -j $(JOBS)

# The main job, `gaussvid reconstruct --adapt`, on the default procedural room, into $(DEMO)/: see
# scripts/demo.sh (its GV_DEMO_* variables change the scene, n and iterations).
run: build
	@bash scripts/demo.sh $(BUILD)/gaussvid $(DEMO)

# `make install PREFIX=DIR` (default /usr/local): the program in DIR/bin, the released models in
# DIR/share/gaussvid, where the program finds them from any folder (docs/RECONSTRUCT.md).
PREFIX ?= /usr/local
install: setup
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=$(PREFIX) >/dev/null
	@cmake --build $(BUILD) -j $(JOBS)
	@cmake --install $(BUILD)

# Tests run two at a time on two cores: OpenMP threads must sleep, not spin, while they
# wait (a spinning wait made 2-thread tests 5-25x slower when oversubscribed).
export OMP_WAIT_POLICY ?= passive

test: build
	@cd $(BUILD) && ctest --output-on-failure -j $(JOBS)
	@$(MAKE) --no-print-directory test-asan
	@$(MAKE) --no-print-directory fuzz FUZZ_SECONDS=10 FUZZ_SEED=1

# The unit tests again under AddressSanitizer and UBSan.
test-asan: setup
	@cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=Debug -DGV_SANITIZE=ON >/dev/null
	@cmake --build $(ASAN_BUILD) -j $(JOBS)
	@cd $(ASAN_BUILD) && ctest --output-on-failure -j $(JOBS) -L unit

# Every reader under libFuzzer with AddressSanitizer and UBSan, one harness at a time
# (fuzz/run.sh; docs/RELIABILITY.md): fails on a crash, leak, slow input or sanitizer report.
fuzz:
	@bash scripts/setup.sh fuzz
	@cmake -S . -B $(FUZZ_BUILD) -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Debug -DGV_FUZZ=ON >/dev/null
	@cmake --build $(FUZZ_BUILD) --target fuzzers -j $(JOBS)
	@FUZZ_SEED=$(FUZZ_SEED) bash fuzz/run.sh $(FUZZ_BUILD) $(FUZZ_SECONDS)

bench: build
	@$(BUILD)/gaussvid bench all

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(FUZZ_BUILD)

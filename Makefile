# stance: two commands on a fresh Debian bookworm machine.
#   make        (make build) install dependencies if missing, build, the Python module in build/python
#   make demo   install dependencies if missing, build (Release), run the main job
#   make test   install dependencies if missing, build, run ctest (every test)
#   make test-fast   the unit and cli tests only (labels: unit, physics, cli, viz)
#   make install     headers, libraries, the stance binary, find_package(stance) and the Python
#                    module (PREFIX/lib/python3.X/dist-packages) into PREFIX
#   make test-sanitize   clang ASan+UBSan tree (build-sanitize/): the readers' unit tests and the
#                        cli tests, then each fuzzer a fixed ~15 s budget (FUZZ_RUN=ci; or seconds)
#   make fuzz SECONDS=N  each fuzzer N seconds (default 60) in the same tree
# CMAKE_FLAGS go to cmake's configure (e.g. CMAKE_FLAGS=-DSTANCE_WITH_PYTHON=ON)
# Ninja, not make: it compiles a layer's files while the layer below still links, which keeps
# both cores busy over the unity build's few large translation units
.DEFAULT_GOAL := build
BUILD ?= build
JOBS ?= $(shell nproc)
STANCE = $(BUILD)/stance
PREFIX ?= /usr/local
CMAKE_FLAGS ?=

SANITIZE_BUILD ?= build-sanitize
# ci: a fixed number of executions per target (about 15 s each) with seed 1, the same everywhere;
# a number: seconds per target, from a random seed
FUZZ_RUN ?= ci
SECONDS ?= 60

.PHONY: demo test test-fast build install deps bench bench-atlas bench-python clean format eval-track \
  robustness-maps compare-seed \
  sanitize-build test-sanitize fuzz

deps:
	@bash scripts/install-deps.sh

$(BUILD)/CMakeCache.txt:
	cmake -G Ninja -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: deps $(BUILD)/CMakeCache.txt
	$(if $(CMAKE_FLAGS),cmake -S . -B $(BUILD) $(CMAKE_FLAGS))
	cmake --build $(BUILD) -j$(JOBS)

test: build
	cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

test-fast: build
	cd $(BUILD) && ctest --output-on-failure -j$(JOBS) -L '^(unit|cli)$$'

$(SANITIZE_BUILD)/CMakeCache.txt:
	CC=clang-14 CXX=clang++-14 cmake -G Ninja -S . -B $(SANITIZE_BUILD) -DCMAKE_BUILD_TYPE=Release \
	  -DSTANCE_SANITIZE=ON -DSTANCE_BUILD_BENCH=OFF -DSTANCE_WITH_VIEWER=OFF -DSTANCE_WITH_PYTHON=OFF \
	  -DSTANCE_WITH_MPI=OFF

sanitize-build: deps $(SANITIZE_BUILD)/CMakeCache.txt
	cmake --build $(SANITIZE_BUILD) -j$(JOBS)

# the fast subset under ASan+UBSan (the install-and-find_package test links outside the tree's
# sanitizer flags, so it stays in `make test`; the DART-MuJoCo mass-matrix cross-check on an MJCF
# chain differs when stance's DART backend is built by clang against Debian's gcc-built DART, with
# no sanitizer report, and stays in `make test` too; the robustness CLI test is batches of
# physics runs, 70 s under ASan, and reads nothing but its own resume file; the robot-limits
# tracking test is three planner runs on Atlas, over 120 s under ASan, reading the URDF that the
# fuzzers and the readers' tests cover), then the fuzzers
MASS_CROSS_CHECK = DartEngine\.AgreesWithMujocoOnAnMjcfChain
test-sanitize: sanitize-build
	cd $(SANITIZE_BUILD) && \
	  LSAN_OPTIONS=suppressions=$(CURDIR)/tests/fuzz/lsan.supp:print_suppressions=0 \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  ctest --output-on-failure -j$(JOBS) -L '^(unit|cli)$$' \
	    -E '^(cli\.find_package|cli\.robustness|cli\.bvh_track_robot_limits|$(MASS_CROSS_CHECK))$$'
	bash tests/fuzz/run.sh $(SANITIZE_BUILD) $(FUZZ_RUN)

fuzz: sanitize-build
	bash tests/fuzz/run.sh $(SANITIZE_BUILD) $(SECONDS)

install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

demo: build
	@bash scripts/demo.sh $(STANCE)

# the benchmarks and the seed's S0 loop in one run, printed as docs/results.md's table
bench: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j$(JOBS) --target stance_bench stance_cli stance_atlas_simbicon_peer
	@bash bench/report.sh $(BUILD)

# docs/results.md's section "The peer: DART's atlas_simbicon" alone (make bench runs it too)
bench-atlas: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j$(JOBS) --target stance_cli stance_atlas_simbicon_peer
	@bash bench/atlas_peer.sh $(BUILD)

# the planner's tracking matrix (not part of CI: about two hours on 2 cores)
eval-track: build
	@bash scripts/eval_track.sh $(BUILD)

# docs/results.md's robustness maps (docs/img/robustness_*.png; 11 minutes on 2 busy cores)
robustness-maps: build
	@bash scripts/robustness_maps.sh $(STANCE)

# S0's push thresholds beside the seed's own dartpy loop, measured in one run (about 3 minutes)
compare-seed: build
	@bash scripts/compare_seed_pushes.sh $(STANCE)

# the Python module's benchmark: the seed's dartpy loop and Python controllers on stance's engines
bench-python: build
	PYTHONPATH=$(BUILD)/python /usr/bin/python3 bench/python_bench.py

format:
	clang-format -i $$(git ls-files '*.cc' '*.h')

clean:
	rm -rf $(BUILD) $(SANITIZE_BUILD)

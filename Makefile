# stance: two commands on a fresh Debian bookworm machine.
#   make demo   install dependencies if missing, build (Release), run the main job
#   make test   install dependencies if missing, build, run ctest (every test)
#   make test-fast   the unit and cli tests only (labels: unit, physics, cli, viz)
#   make install     headers, libraries, the stance binary and find_package(stance) into PREFIX
BUILD ?= build
JOBS ?= $(shell nproc)
STANCE = $(BUILD)/stance
PREFIX ?= /usr/local

.PHONY: demo test test-fast build install deps bench clean format eval-track

deps:
	@bash scripts/install-deps.sh

$(BUILD)/CMakeCache.txt:
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release

build: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j$(JOBS)

test: build
	cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

test-fast: build
	cd $(BUILD) && ctest --output-on-failure -j$(JOBS) -L '^(unit|cli)$$'

install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

demo: build
	@bash scripts/demo.sh $(STANCE)

# the benchmarks and the seed's S0 loop in one run, printed as the README's table
bench: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j$(JOBS) --target stance_bench
	@bash bench/report.sh $(BUILD)

# the planner's tracking matrix (not part of CI: about two hours on 2 cores)
eval-track: build
	@bash scripts/eval_track.sh $(BUILD)

format:
	clang-format -i $$(git ls-files '*.cc' '*.h')

clean:
	rm -rf $(BUILD)

# stance: two commands on a fresh Debian bookworm machine.
#   make        (make build) install dependencies if missing, build, the Python module in build/python
#   make demo   install dependencies if missing, build (Release), run the main job
#   make test   install dependencies if missing, build, run ctest (every test)
#   make test-fast   the unit and cli tests only (labels: unit, physics, cli, viz)
#   make install     headers, libraries, the stance binary, find_package(stance) and the Python
#                    module (PREFIX/lib/python3.X/dist-packages) into PREFIX
# CMAKE_FLAGS go to cmake's configure (e.g. CMAKE_FLAGS=-DSTANCE_WITH_PYTHON=ON)
.DEFAULT_GOAL := build
BUILD ?= build
JOBS ?= $(shell nproc)
STANCE = $(BUILD)/stance
PREFIX ?= /usr/local
CMAKE_FLAGS ?=

.PHONY: demo test test-fast build install deps bench bench-python clean format

deps:
	@bash scripts/install-deps.sh

$(BUILD)/CMakeCache.txt:
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: deps $(BUILD)/CMakeCache.txt
	$(if $(CMAKE_FLAGS),cmake -S . -B $(BUILD) $(CMAKE_FLAGS))
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

# the Python module's benchmark: the seed's dartpy loop and Python controllers on stance's engines
bench-python: build
	PYTHONPATH=$(BUILD)/python /usr/bin/python3 bench/python_bench.py

format:
	clang-format -i $$(git ls-files '*.cc' '*.h')

clean:
	rm -rf $(BUILD)

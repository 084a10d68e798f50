# Thin wrapper over CMake presets. `make demo` and `make test` install missing Debian packages,
# configure, build and run. `make test` runs the suite twice: optimised (release) and under
# AddressSanitizer + UndefinedBehaviorSanitizer (asan), the latter without the whole-session
# suites labelled `slow`. `make check PRESET=debug|release|asan` runs one build's suite.
PRESET ?= release
BUILD  := build/$(PRESET)
JOBS   ?= $(shell nproc)

.PHONY: all deps configure build test check demo docs-picture format clean

all: build

deps:
	@bash deploy/install-deps.sh

configure: deps
	@cmake --preset $(PRESET) >/dev/null

build: configure
	@cmake --build --preset $(PRESET) -j $(JOBS)

check: build
	@ctest --preset $(PRESET) -j $(JOBS) $(CTEST_ARGS)

test: deps
	@$(MAKE) --no-print-directory check PRESET=release
	@$(MAKE) --no-print-directory check PRESET=asan CTEST_ARGS="-LE slow"

demo: build
	@bash tools/demo.sh $(BUILD)

# Regenerates the README picture: the default workshop seen from 8 m, LiDAR points projected.
docs-picture: build
	@mkdir -p docs /tmp/calibd-docs
	@$(BUILD)/tools/sim/calibd-sim --quiet --seed 1 --trajectory static --static-distance 8 --frames 1 \
	  --overlay-frame 0 --overlay-scale 0.4 --overlay-png docs/sim_frame.png --out /tmp/calibd-docs/picture.lcmlog
	@rm -rf /tmp/calibd-docs

format:
	@find core drivers agent tools tests lcm_types \( -name '*.cpp' -o -name '*.hpp' \) -print0 2>/dev/null | xargs -0 clang-format -i

clean:
	@rm -rf build

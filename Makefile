# Thin wrapper over CMake presets. `make demo` and `make test` install missing Debian packages,
# configure, build and run. `make test` runs the suite twice: optimised (release) and under
# AddressSanitizer + UndefinedBehaviorSanitizer (asan), the latter without the whole-session
# suites labelled `slow`, the simulator's own suites (`sim`) and the VM tests labelled `vm`
# (tests/vm/: kernel I/O, not memory);
# then every libFuzzer target for a short fixed time from its seed corpus (fuzz-smoke); last, the
# aarch64 cross build and core's suites under qemu (cross-test).
# The sanitizer build is clang at -O1 -g1 (ASan's recommended level, line tables for its stack
# traces), and holds the libFuzzer targets too: one sanitizer build instead of two.
# `make check PRESET=debug|release|asan` runs one build's suite.
PRESET ?= release
BUILD  := build/$(PRESET)
JOBS   ?= $(shell nproc)

# `make install`: installs the release build under PREFIX, staged under DESTDIR when set
# (cmake/CalibdInstall.cmake lists the files). PREFIX defaults to /usr, a vehicle image's layout:
# /usr/bin/calibd-agent, /etc/calibd/calibd.yaml, /usr/lib/systemd/system/calibd.service.
PREFIX ?= /usr

.PHONY: all deps configure build test check demo docs-picture format clean install cross-test \
  fuzz-build fuzz-smoke fuzz

all: build

deps:
	@bash deploy/install-deps.sh

configure: deps
	@cmake --preset $(PRESET) >/dev/null

build: configure
	@cmake --build --preset $(PRESET) -j $(JOBS) $(if $(BUILD_TARGET),--target $(BUILD_TARGET))

check: build
	@ctest --preset $(PRESET) -j $(JOBS) $(CTEST_ARGS)

# Each phase's wall time is printed at the end (tests/timed_phase.sh; build/phase-times.tsv).
PHASE := CALIBD_PHASES=build/phase-times.tsv bash tests/timed_phase.sh
test: deps
	@mkdir -p build && rm -f build/phase-times.tsv
	@$(PHASE) "release: build without the unit suites" $(MAKE) --no-print-directory build PRESET=release \
	  BUILD_TARGET=calibd_optimised_pass
	@$(PHASE) "release: suite without unit (aarch64 build beside)" bash tests/beside.sh \
	  build/cross-build.log "CALIBD_CROSS_BUILD_ONLY=1 JOBS=$(JOBS) bash toolchains/cross-test.sh" \
	  ctest --preset release -j $(JOBS) -L 'slow|sim|vm|both|check'
	@$(PHASE) "asan: build (with the fuzz targets)" $(MAKE) --no-print-directory build PRESET=asan
	@$(PHASE) "asan: suite without slow, vm, fuzz" ctest --preset asan -j $(JOBS) -LE 'slow|vm|fuzz'
	@$(PHASE) "fuzz: smoke" ctest --preset asan -j $(FUZZ_JOBS) -L fuzz
	@$(PHASE) "aarch64: rest of the build, core suites (qemu)" $(MAKE) --no-print-directory cross-test
	@echo "make test: phase times"; $(PHASE) --print

install:
	@$(MAKE) --no-print-directory build PRESET=release
	@DESTDIR="$(DESTDIR)" cmake --install build/release --prefix "$(PREFIX)"

demo: build
	@bash tools/demo.sh $(BUILD)

# The aarch64 cross build (preset aarch64): core, its tests and calibd-agent, then the core suites
# under qemu user emulation. Installs the cross compiler, qemu-user-static and an arm64 sysroot
# (~/.cache/calibd/aarch64-sysroot, once per machine) when missing; see toolchains/cross-test.sh.
# CTEST_ARGS go to its ctest. The last phase of `make test`.
cross-test:
	@JOBS=$(JOBS) bash toolchains/cross-test.sh $(CTEST_ARGS)

# libFuzzer targets (tests/fuzz/, in the sanitizer build: preset asan, clang, ASan+UBSan):
# `make fuzz-smoke` builds only them and runs each for 5 s from its seed corpus (ctest -L fuzz;
# part of `make test`); `make fuzz FUZZ_SECONDS=600` runs each for FUZZ_SECONDS, FUZZ_JOBS at a
# time, and prints executions and coverage per target. Both fuzz copies of the corpora in
# build/asan/tests/fuzz/; crash inputs land in their artifacts/.
FUZZ_SECONDS ?= 600
FUZZ_JOBS    ?= 2
FUZZ_DIR     := build/asan/tests/fuzz
fuzz-build: deps
	@cmake --preset asan >/dev/null
	@cmake --build --preset asan -j $(JOBS) --target calibd_fuzz_targets

fuzz-smoke: fuzz-build
	@ctest --preset asan -j $(FUZZ_JOBS) -L fuzz $(CTEST_ARGS)

fuzz: fuzz-build
	@printf '%-26s %12s %8s %7s %7s %6s  %s\n' target executions exec/s cov ft corpus result
	@ls $(FUZZ_DIR)/fuzz_* | grep -v '\.' | xargs -P $(FUZZ_JOBS) -I{} sh -c \
	  'bash tests/fuzz/run_fuzz.sh {} tests/fuzz/corpus/$$(basename {} | sed s/^fuzz_//) \
	   $(FUZZ_DIR)/long/$$(basename {}) $(FUZZ_SECONDS) || true'

# Regenerates docs/sim_frame.png (docs/simulator.md): the default workshop seen from 8 m, LiDAR points projected.
docs-picture: build
	@mkdir -p docs /tmp/calibd-docs
	@$(BUILD)/tools/sim/calibd-sim --quiet --seed 1 --trajectory static --static-distance 8 --frames 1 \
	  --overlay-frame 0 --overlay-scale 0.4 --overlay-png docs/sim_frame.png --out /tmp/calibd-docs/picture.lcmlog
	@rm -rf /tmp/calibd-docs

format:
	@find core drivers agent tools tests lcm_types \( -name '*.cpp' -o -name '*.hpp' \) -print0 2>/dev/null | xargs -0 clang-format -i

clean:
	@rm -rf build

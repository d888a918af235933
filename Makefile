# Front door. `make demo` runs the main job, `make test` builds and runs every test.
# Both install the missing Debian 12 packages first (apt-get; sudo when not root).
SHELL := /bin/bash
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
DEB_PACKAGES := cmake ninja-build g++ pkg-config libeigen3-dev libtbb-dev libspdlog-dev \
  libgtest-dev libgmock-dev libbenchmark-dev cyclonedds-dev cyclonedds-tools libyaml-cpp-dev \
  nlohmann-json3-dev libcli11-dev clang-format zlib1g-dev libpng-dev clang libclang-rt-14-dev iptables
# DDS Security tests and profile (config/security/make_test_pki.sh)
DEB_PACKAGES += openssl
# sd_notify (Type=notify unit); `make package` and tests/package: CPack's DEB generator
# runs dpkg-shlibdeps (dpkg-dev), file and readelf (binutils)
DEB_PACKAGES += libsystemd-dev dpkg-dev file binutils
# Network namespaces for the DDS tests (run_isolated.sh) and the several-host tests
# (virtual_lan.cpp: veth pairs; skipped with the reason where namespaces are not allowed)
DEB_PACKAGES += iproute2
# The Python module (client/python, docs/PYTHON.md), its tests and examples/python
DEB_PACKAGES += pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib
# The peers of bench_peers and peers_exact_test (FCL 0.7, CGAL 5.5; both optional at build time)
DEB_PACKAGES += libfcl-dev libcgal-dev
# The daemon's Prometheus endpoint, metrics.listen (docs/DEPLOYMENT.md "Metrics"): a
# required build dependency (its run-time libraries are in the tetcollided package's
# Depends through dpkg-shlibdeps)
DEB_PACKAGES += prometheus-cpp-dev
# examples/bullet: the Bullet soft-body example and its test (optional: skipped without it)
DEB_PACKAGES += libbullet-dev
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps build test test-asan test-tsan test-tsan-unit fuzz fuzz-short fuzz-build demo format \
  format-check bench clean help reliability load soak package example-python
# Seconds each fuzz target runs in `make fuzz` / `make fuzz-short` (CI).
FUZZ_SECONDS ?= 60
FUZZ_SHORT_SECONDS ?= 15

all: build

help:
	@echo "make deps        install missing Debian packages"
	@echo "make build       Release build, executables in $(BUILD_DIR)/bin/"
	@echo "make test        deps + build + all tests (ctest)"
	@echo "make test-asan   every test under ASan+UBSan (build/asan-ubsan)"
	@echo "make test-tsan   the daemon's tests under TSan (build/tsan)"
	@echo "make test-tsan-unit  the daemon's unit tests only under TSan (CI)"
	@echo "make fuzz        libFuzzer targets, FUZZ_SECONDS=$(FUZZ_SECONDS) s each (build/asan-ubsan)"
	@echo "make fuzz-short  the same, FUZZ_SHORT_SECONDS=$(FUZZ_SHORT_SECONDS) s each (CI)"
	@echo "make demo        the main job (daemon with contact stiffness blocks)"
	@echo "make package     Debian packages in $(BUILD_DIR)/packages/ (docs/DEPLOYMENT.md)"
	@echo "make example-python  NumPy simulators: a ball dropped on the box, an STL tool dragged across an organ"
	@echo "make format      clang-format every source file"
	@echo "make reliability fault tests: killed client, 10 restarts, loss, SIGSTOP"
	@echo "make load        4 clients x 2 objects x 60 Hz, 60,000-node objects"
	@echo "make soak        3 minutes, 20 register/unregister cycles while streaming; fails"
	@echo "                 when the daemon's live heap grows per cycle (docs/RELIABILITY.md)"

deps:
	@missing=$$(for p in $(DEB_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q 'install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing missing Debian packages: $$missing"; \
	  $(SUDO) apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq --no-install-recommends $$missing; \
	fi

$(BUILD_DIR)/build.ninja:
	cmake --preset release -B $(BUILD_DIR)

build: deps $(BUILD_DIR)/build.ninja
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

test-asan: deps
	cmake --preset asan-ubsan
	cmake --build --preset asan-ubsan -j $(JOBS)
	ctest --preset asan-ubsan -j $(JOBS)

# Only the daemon's tests (tests/service, tests/integration) and the programs they run.
test-tsan: deps
	cmake --preset tsan
	cmake --build --preset tsan -j $(JOBS)
	ctest --preset tsan -j $(JOBS)

# CI's TSan stage: the daemon's unit tests (tests/service, real TBB threads, no DDS) in the
# same tree; `make test-tsan` adds the integration tests (real daemon processes over DDS).
test-tsan-unit: deps
	cmake --preset tsan
	cmake --build build/tsan -j $(JOBS) --target tc_daemon_unit_tests
	ctest --preset tsan -j $(JOBS) -R '^service\.'

fuzz-build: deps
	cmake --preset asan-ubsan
	cmake --build --preset fuzz -j $(JOBS)

fuzz: fuzz-build
	FUZZ_SECONDS=$(FUZZ_SECONDS) ./scripts/fuzz.sh

fuzz-short: fuzz-build
	FUZZ_SECONDS=$(FUZZ_SHORT_SECONDS) ./scripts/fuzz.sh

# Builds only what the demo runs (a full `make build` takes longer than the demo's budget).
demo: deps $(BUILD_DIR)/build.ninja
	cmake --build $(BUILD_DIR) -j $(JOBS) --target tetcollide tetcollided
	./scripts/demo.sh

# The Debian packages (packaging/Packaging.cmake) of the Release tree: tetcollided,
# libtetcollide-client, libtetcollide-client-dev, tetcollide-tools. Builds only what
# they hold; tests/package checks them (`ctest -L package`).
package: deps $(BUILD_DIR)/build.ninja
	cmake --build $(BUILD_DIR) -j $(JOBS) --target tetcollided tetcollide
	cd $(BUILD_DIR) && cpack -G DEB -B $(abspath $(BUILD_DIR))/packages
	@ls -1 $(BUILD_DIR)/packages/*.deb

# examples/python/drop_ball.py and tool_drag.py (docs/PYTHON.md, docs/SURFACES.md) with
# the interpreter the module is built for (Debian's /usr/bin/python3, which may not be the
# python3 first on PATH); each starts and stops its own daemon. Outputs in
# out/python_drop_ball/ and out/python_tool_drag/.
example-python: deps $(BUILD_DIR)/build.ninja
	cmake --build $(BUILD_DIR) -j $(JOBS) --target tetcollided tetcollide_python
	py=$$(sed -n 's/^TC_PYTHON_EXECUTABLE:INTERNAL=//p' $(BUILD_DIR)/CMakeCache.txt); \
	for example in drop_ball tool_drag; do \
	  PYTHONPATH=$(BUILD_DIR)/python $${py:-python3} examples/python/$$example.py \
	    --daemon $(BUILD_DIR)/bin/tetcollided || exit 1; \
	done

bench: build
	./scripts/bench.sh

# CPU and latency cost of the DDS Security profile (docs/RELIABILITY.md, "DDS Security").
.PHONY: bench-security
bench-security: build
	./bench/security_cost.sh $(BUILD_DIR)

# docs/RELIABILITY.md: fault tests (also part of `make test`), load and soak figures.
reliability: build
	set -o pipefail; cd $(BUILD_DIR) && ctest -L reliability --output-on-failure -V | grep -E '\[ figure \]|tests passed|Failed|Test +#'

load: build
	tests/integration/run_isolated.sh $(BUILD_DIR)/bin/service_load --daemon $(BUILD_DIR)/bin/tetcollided

soak: build
	tests/integration/run_isolated.sh $(BUILD_DIR)/bin/service_load --soak --daemon $(BUILD_DIR)/bin/tetcollided

format:
	git ls-files '*.cpp' '*.hpp' 'service/*.inc' | xargs clang-format -i

format-check:
	git ls-files '*.cpp' '*.hpp' 'service/*.inc' | xargs clang-format --dry-run -Werror

clean:
	rm -rf $(BUILD_DIR)

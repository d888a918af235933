# Front door. `make demo` runs the main job, `make test` builds and runs every test.
# Both install the missing Debian 12 packages first (apt-get; sudo when not root).
SHELL := /bin/bash
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
DEB_PACKAGES := cmake ninja-build g++ pkg-config libeigen3-dev libtbb-dev libspdlog-dev \
  libgtest-dev libgmock-dev libbenchmark-dev cyclonedds-dev cyclonedds-tools libyaml-cpp-dev \
  nlohmann-json3-dev libcli11-dev clang-format zlib1g-dev libpng-dev
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps build test test-asan demo format format-check bench clean help

all: build

help:
	@echo "make deps        install missing Debian packages"
	@echo "make build       Release build, executables in $(BUILD_DIR)/bin/"
	@echo "make test        deps + build + all tests (ctest)"
	@echo "make test-asan   unit tests under ASan+UBSan (build/asan-ubsan)"
	@echo "make demo        the main job on embedded defaults"
	@echo "make format      clang-format every source file"

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
	cmake --build build/asan-ubsan -j $(JOBS)
	ctest --preset asan-ubsan -j $(JOBS)

# Builds only what the demo runs (a full `make build` takes longer than the demo's budget).
demo: deps $(BUILD_DIR)/build.ninja
	cmake --build $(BUILD_DIR) -j $(JOBS) --target tetcollide tetcollided
	./scripts/demo.sh

bench: build
	./scripts/bench.sh

format:
	git ls-files '*.cpp' '*.hpp' | xargs clang-format -i

format-check:
	git ls-files '*.cpp' '*.hpp' | xargs clang-format --dry-run -Werror

clean:
	rm -rf $(BUILD_DIR)

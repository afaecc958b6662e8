# The two commands of the README, and the steps they are made of. Every target installs what is
# missing (tools/setup.sh), configures once and rebuilds only what changed.
JOBS ?= 2
TELLUS := build/tools/tellus/tellus
CACHE ?= var/cache

.PHONY: all setup build run test test-release test-sanitizers bench format clean

all: build

setup:
	@tools/setup.sh

build/build.ninja: | setup
	cmake --preset release

build: setup build/build.ninja
	cmake --build build -j$(JOBS)
	@ln -sf build/compile_commands.json compile_commands.json

# The main job on the embedded default (bundled Blue Marble + ETOPO 20'): fill the cache (levels
# 0-1, resumable), show it, and serve it on LISTEN until Ctrl-C.
LISTEN ?= 127.0.0.1:8080
run: build
	$(TELLUS) seed --cache $(CACHE) --levels 0-1
	$(TELLUS) cache stats --cache $(CACHE)
	$(TELLUS) serve --cache $(CACHE) --listen $(LISTEN)

# Every test: Release (GL tests under xvfb-run), then the ASan+UBSan and TSan configurations.
test: test-release test-sanitizers

test-release: build
	cd build && ctest --output-on-failure -j$(JOBS) -LE gl
	cd build && if [ -n "$$(ctest -N -L gl | grep 'Test #')" ]; then \
	  xvfb-run -a -s '-screen 0 1280x1024x24' ctest --output-on-failure -L gl; fi

test-sanitizers: setup
	@[ -f build-asan/build.ninja ] || cmake --preset asan-ubsan
	cmake --build build-asan -j$(JOBS)
	cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --output-on-failure -j$(JOBS) -LE 'gl|slow'
	@[ -f build-tsan/build.ninja ] || cmake --preset tsan
	cmake --build build-tsan -j$(JOBS)
	cd build-tsan && TSAN_OPTIONS=halt_on_error=1 ctest --output-on-failure -j$(JOBS) -LE 'gl|slow'

bench: build
	bench/run.sh

format:
	git ls-files '*.cpp' '*.hpp' | xargs clang-format -i

clean:
	rm -rf build build-debug build-asan build-tsan var

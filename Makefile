# The two commands of the README, and the steps they are made of. Every target installs what is
# missing (tools/setup.sh), configures once and rebuilds only what changed.
JOBS ?= 2
TELLUS := build/tools/tellus/tellus
CACHE ?= var/cache

.PHONY: all setup build run test test-release test-sanitizers fuzz bench format format-check clean web-page

all: build

setup:
	@tools/setup.sh

build/build.ninja: | setup
	cmake --preset release

build: setup build/build.ninja
	cmake --build build -j$(JOBS)
	@ln -sf build/compile_commands.json compile_commands.json

# The main job on the embedded default (bundled Blue Marble + ETOPO 20'): fill the cache (levels
# 0-1, resumable), show it, and serve it on LISTEN until Ctrl-C. With a display, the globe opens in
# `tellus view` on the same cache while the server runs; closing the window stops both.
LISTEN ?= 127.0.0.1:8080
run: build
	$(TELLUS) seed --cache $(CACHE) --levels 0-1
	$(TELLUS) cache stats --cache $(CACHE)
	@if [ -n "$$DISPLAY" ]; then \
	  $(TELLUS) serve --cache $(CACHE) --listen $(LISTEN) & server=$$!; \
	  $(TELLUS) view --cache $(CACHE); rc=$$?; kill $$server; wait $$server; exit $$rc; \
	else \
	  $(TELLUS) serve --cache $(CACHE) --listen $(LISTEN); \
	fi

# Every test: the format check first (seconds), then Release (every test; GL tests under
# xvfb-run with -noreset (an X server resets when its last client leaves, and a test opening the
# display again meanwhile failed: DomeGl once), one at a time: the TerrainViewGl tests give their
# loading 60 s of wall clock and ran out of it at -j2 on a loaded 2-core machine; the interop
# tests: GDAL, OWSLib, Chromium), then the ASan+UBSan configuration (every test but gl, slow and
# interop: those programs are not ours to sanitize, and repeating them there only timed out) and
# the TSan one (of those, the tests whose
# code runs threads: TELLUS_THREAD_TESTS_ONLY in its preset, tests/CMakeLists.txt), then a short
# fuzzing run of the request parsers. The page at / is bundled once, in the Release tree, and
# embedded from there by the sanitizer trees (TELLUS_WEB_DIST_FROM); the fuzz tree builds only
# the parsers. Each stage says how long it took, and each ctest run where its time went
# (tools/test-times).
# On CI (a fresh machine, no ccache) compiling the four trees from scratch (~1,130 files) is most
# of its time. Every tree but the debug preset is a unity build (TELLUS_UNITY_BUILD,
# CMakeLists.txt: batches of 8 files a translation unit), which built an ASan+UBSan sample in
# 0.69x the CPU of file by file; the four trees are estimated at ~0.70x (bench/RESULTS.md, "CI
# build CPU"). -DTELLUS_UNITY_BUILD=OFF compiles file by file.
test: format-check test-release test-sanitizers fuzz

format-check:
	@git ls-files '*.cpp' '*.hpp' | xargs clang-format --dry-run --Werror || \
	  { echo "format-check: the files above drift from .clang-format; run make format"; exit 1; }

WEB_DIST := $(CURDIR)/build/proxy/web-dist
web-page: setup build/build.ninja
	cmake --build build -j$(JOBS) --target tellus_web_page

SANITIZER_CTEST := ctest --output-on-failure -j$(JOBS) -LE 'gl|slow|interop'

test-release: build
	@start=$$(date +%s); \
	cd build && ctest --output-on-failure -j$(JOBS) -LE gl --output-junit test-times.xml; rc=$$?; \
	../tools/test-times test-times.xml; [ $$rc = 0 ] || exit $$rc; \
	if [ -n "$$(ctest -N -L gl | grep 'Test #')" ]; then \
	  xvfb-run -a -s '-screen 0 1280x1024x24 -noreset' ctest --output-on-failure -L gl \
	    --output-junit test-times-gl.xml; rc=$$?; ../tools/test-times test-times-gl.xml; \
	  [ $$rc = 0 ] || exit $$rc; fi; \
	echo "test-release: tests took $$(( $$(date +%s) - start )) s"

test-sanitizers: web-page
	@start=$$(date +%s); \
	[ -f build-asan/build.ninja ] || cmake --preset asan-ubsan -DTELLUS_WEB_DIST_FROM=$(WEB_DIST); \
	cmake --build build-asan -j$(JOBS) || exit 1; \
	echo "test-sanitizers: ASan+UBSan tree built in $$(( $$(date +%s) - start )) s"; \
	cd build-asan && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  LSAN_OPTIONS=suppressions=$(CURDIR)/tools/sanitizers/lsan.supp \
	  $(SANITIZER_CTEST) --output-junit test-times.xml; rc=$$?; \
	../tools/test-times test-times.xml; [ $$rc = 0 ] || exit $$rc; cd ..; \
	start=$$(date +%s); \
	[ -f build-tsan/build.ninja ] || cmake --preset tsan -DTELLUS_WEB_DIST_FROM=$(WEB_DIST); \
	cmake --build build-tsan -j$(JOBS) || exit 1; \
	echo "test-sanitizers: TSan tree built in $$(( $$(date +%s) - start )) s"; \
	cd build-tsan && TSAN_OPTIONS="halt_on_error=1 suppressions=$(CURDIR)/tools/sanitizers/tsan.supp" \
	  $(SANITIZER_CTEST) --output-junit test-times.xml; rc=$$?; \
	../tools/test-times test-times.xml; exit $$rc

# libFuzzer on the request parsers and the image decoders (fuzz/, clang, ASan+UBSan): each target
# runs FUZZ_SECONDS on a copy of its seeds (build-fuzz/corpus-work/<target>, which keeps what it
# finds between runs; the seeds in fuzz/corpus/ are not touched). Any crash, sanitizer report,
# leak, slow input (-timeout) or memory blow-up fails the target; the input lands in
# build-fuzz/artifacts/<target>/ and the log in build-fuzz/<target>.log. Replay one:
# build-fuzz/fuzz/<target> <file>.
FUZZ_SECONDS ?= 20
FUZZ_TARGETS := fuzz_query fuzz_static_path fuzz_config fuzz_codec fuzz_values fuzz_wmts_capabilities
fuzz: setup
	@[ -f build-fuzz/build.ninja ] || cmake --preset fuzz
	cmake --build build-fuzz -j$(JOBS) --target tellus_fuzz
	@set -e; for t in $(FUZZ_TARGETS); do \
	  case $$t in fuzz_config) dict=fuzz/config.dict;; fuzz_codec|fuzz_values) dict=fuzz/codec.dict;; \
	    fuzz_wmts_capabilities) dict=fuzz/wmts.dict;; \
	    *) dict=fuzz/wms.dict;; esac; \
	  mkdir -p build-fuzz/corpus-work/$$t build-fuzz/artifacts/$$t; \
	  cp fuzz/corpus/$$t/* build-fuzz/corpus-work/$$t/; \
	  echo "fuzz: $$t for $(FUZZ_SECONDS) s (log: build-fuzz/$$t.log)"; \
	  if ! ASAN_SYMBOLIZER_PATH=/usr/bin/llvm-symbolizer-16 UBSAN_OPTIONS=print_stacktrace=1 \
	      build-fuzz/fuzz/$$t -max_total_time=$(FUZZ_SECONDS) \
	      -rss_limit_mb=2048 -timeout=10 -dict=$$dict -artifact_prefix=build-fuzz/artifacts/$$t/ \
	      -print_final_stats=1 build-fuzz/corpus-work/$$t > build-fuzz/$$t.log 2>&1; then \
	    tail -n 60 build-fuzz/$$t.log; echo "fuzz: $$t FAILED, input in build-fuzz/artifacts/$$t/"; \
	    exit 1; \
	  fi; \
	  grep -E '^(Done|stat::new_units_added)' build-fuzz/$$t.log || true; \
	done

bench: build
	bench/run.sh

# Cached tiles through tellus serve against nginx on the same files, and RSS with 1,000 idle
# connections (needs wrk and nginx: apt-get install --no-install-recommends wrk nginx-light).
.PHONY: bench-proxy
bench-proxy: build
	bench/proxy/run.sh

# tellus against MapProxy and MapCache in front of one local MapServer (bench/peers/README.md).
# Installs its own extras on the first run (apache2-bin, mod_mapcache, mod_fcgid, mapcache-tools;
# MapProxy and gunicorn in a venv under build/peers-bench); not part of `make test`.
.PHONY: bench-peers
bench-peers: build
	bench/peers/run.sh

format:
	git ls-files '*.cpp' '*.hpp' | xargs clang-format -i

clean:
	rm -rf build build-debug build-asan build-tsan build-fuzz var

#!/usr/bin/env bash
# Runs the tile cache benchmarks (what `make bench` calls) and prints their results.
#
#   bench/run.sh [BINARY_DIR] [benchmark options...]
#
# BINARY_DIR is the CMake build directory (default: build, as configured by `cmake --preset release`
# with TELLUS_BUILD_BENCH=ON). Further options go to Google Benchmark, e.g.
#   bench/run.sh build --benchmark_filter=BM_Put
# The full run takes about 1-2 minutes on a 2-vCPU machine. Besides the console table and the
# summary (ratios against the goals of the cache issue), the results are written as JSON to
# BINARY_DIR/bench/cache-results.json. Fixtures (a 1,000,000-tile index, tile files) go to a
# temporary directory below $TELLUS_BENCH_DIR (default: $TMPDIR or /tmp) that is removed afterwards.
# Record figures worth keeping in bench/RESULTS.md.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bin_dir="${1:-$repo/build}"
[[ $# -gt 0 ]] && shift

exe="$bin_dir/bench/tellus_bench_cache"
if [[ ! -x "$exe" ]]; then
  echo "run.sh: $exe not found; build it first (cmake --preset release && cmake --build build -j2," >&2
  echo "        with TELLUS_BUILD_BENCH=ON, the default)" >&2
  exit 1
fi

base="${TELLUS_BENCH_DIR:-${TMPDIR:-/tmp}}"
mkdir -p "$base"
work="$(mktemp -d "$base/tellus-bench-run.XXXXXX")"
trap 'rm -rf "$work"' EXIT
trap 'exit 130' INT TERM

echo "== tellus cache benchmarks: $(date -u '+%Y-%m-%d %H:%M:%S UTC'), $(nproc) CPU(s), load: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "== binary: $exe"
echo "== fixtures in: $work (filesystem: $(df -PT "$work" | awk 'NR == 2 { print $2 }'))"
TELLUS_BENCH_DIR="$work" "$exe" \
  --benchmark_out="$bin_dir/bench/cache-results.json" --benchmark_out_format=json \
  "$@"
echo "== JSON results: $bin_dir/bench/cache-results.json"

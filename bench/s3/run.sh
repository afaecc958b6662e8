#!/usr/bin/env bash
# Hits from the shared S3 store against hits from the local tier (issue 27): starts the test S3
# server (tests/support/s3-server.sh: Swift + s3api on loopback), runs tellus_bench_s3_hits
# (bench/BenchS3Hits.cpp) and stops the server. Figures go to bench/RESULTS.md, "Hits from S3".
# Usage: bench/s3/run.sh [BUILD_DIR] [TILES] [READS_PER_ROUND] [ROUNDS]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-bench-s3.XXXXXX")
trap '"$root/tests/support/s3-server.sh" stop "$work/s3" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
"$root/tests/support/s3-server.sh" start "$work/s3" | grep START_MS
"$build/bench/tellus_bench_s3_hits" "$work/s3/s3.env" "$work" "${2:-200}" "${3:-2000}" "${4:-3}"

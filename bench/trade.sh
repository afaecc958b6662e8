#!/usr/bin/env bash
# The speed/accuracy trade, measured (issue #8). One knob at a time from the defaults (threshold 1,
# 33 vertices, WGS84, geoid on, double vertices, 8 MiB uploads a frame), three fixed views (global,
# oblique over the Alps, low over the Alps), `tellus render --wait-complete --stats` on a warm cache
# (bench/trade.yaml: the bundled data with deeper levels). Each setting renders its view as a
# static flight of 16 frames (--path, two equal keyframes 0.6 s apart at 25 fps): the first frame
# streams until complete, the other 15 are the settled view, whose median frame, process CPU and
# update times are reported. Image error: PSNR against the maximum-quality render of the same view (threshold
# 0.5, 65 vertices, WGS84, geoid, double); geometric error in metres: bench/TradeGeometry.cpp
# (tellus_trade_geometry, GL-free, against GeographicLib). bench/trade.py joins them into
# bench/trade/trade.csv and bench/trade/geometry.csv and draws bench/trade/*.png.
# Mesa llvmpipe under Xvfb draws on the CPU: frame times are CPU figures.
# Usage: bench/trade.sh [BUILD_DIR]   (default build; needs python3-numpy, python3-matplotlib)
set -euo pipefail
build=${1:-build}
tellus=$build/tools/tellus/tellus
geometry=$build/bench/tellus_trade_geometry
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
out=$here/trade
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-trade.XXXXXX")
trap 'rm -rf "$work"' EXIT
cache=$work/cache
size=${TRADE_SIZE:-640x480}
mkdir -p "$out"

declare -A views=(
  [global]="20,10,7e6,0,0"
  [alps]="44.0,7.5,1.5e5,0,55"
  [low]="46.4,8.0,1.2e4,0,45"
)
order=(global alps low)

render() { # view name args...
  local view=$1 name=$2
  shift 2
  IFS=, read -r lat lon alt hdg tilt <<<"${views[$view]}"
  cat >"$work/path.json" <<JSON
[{"time": 0, "lat": $lat, "lon": $lon, "alt": $alt, "heading": $hdg, "tilt": $tilt},
 {"time": 0.6, "lat": $lat, "lon": $lon, "alt": $alt, "heading": $hdg, "tilt": $tilt}]
JSON
  rm -rf "$work/frames"
  xvfb-run -a -s '-screen 0 1280x1024x24' "$tellus" render --config "$here/trade.yaml" \
    --cache "$cache" --path "$work/path.json" --frames "$work/frames" --fps 25 --size "$size" \
    --wait-complete=120 --stats "$work/runs/$view-$name.json" "$@" >/dev/null
  cp "$work/frames/frame_00015.png" "$work/runs/$view-$name.png"
  printf '%s\t%s\t%s\n' "$view" "$name" "$*" >>"$work/runs/manifest.tsv"
}

mkdir -p "$work/runs"
: >"$work/runs/manifest.tsv"
# TRADE_KEEP=DIR keeps the renders (images, statistics) there for a second look at them.
# Warm the cache: every tile the sweep will ask for (threshold 0.5 wants the most), and ETOPO
# over the views' region for the geometric reference.
"$tellus" seed --config "$here/trade.yaml" --cache "$cache" --layer etopo --levels 0-1 >/dev/null
"$tellus" seed --config "$here/trade.yaml" --cache "$cache" --layer etopo --levels 2-6 \
  --bbox 5,43,11,49 >/dev/null
for v in "${order[@]}"; do
  render "$v" warmup --threshold 0.5 --mesh-size 65
  render "$v" warmup2 --threshold 0.5 --earth sphere
done
: >"$work/runs/manifest.tsv"

for v in "${order[@]}"; do
  echo "trade: $v" >&2
  render "$v" reference --threshold 0.5 --mesh-size 65
  render "$v" default
  for t in 0.5 2 4; do render "$v" "threshold=$t" --threshold "$t"; done
  for n in 9 17 65; do render "$v" "mesh=$n" --mesh-size "$n"; done
  render "$v" earth=sphere --earth sphere
  render "$v" geoid=off --geoid off
  render "$v" vertices=float --vertices float
  for u in 524288 2097152 33554432; do render "$v" "upload=$u" --upload-per-frame "$u"; done
done

etopo=$(find "$cache" -maxdepth 2 -type d -name 'etopo-*' | head -1)
"$geometry" --data "$here/../data" --etopo "$etopo" >"$out/geometry.csv"
# Debian's python3 (python3-numpy, python3-matplotlib), not another one earlier on the PATH.
py=${PYTHON:-$(command -v /usr/bin/python3 || command -v python3)}
"$py" "$here/trade.py" "$work/runs" "$out"
if [ -n "${TRADE_KEEP:-}" ]; then
  rm -rf "$TRADE_KEEP" && cp -r "$work/runs" "$TRADE_KEEP"
fi

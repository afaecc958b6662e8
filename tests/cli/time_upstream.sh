# Sourced by the tests of a layer whose every time is a colour of its own (test_animate.sh,
# test_cluster_times.sh; they set work, here, data and fail). time_upstream_config FILE: starts
# time_upstream.py on a free port (its pid in upstream_pid: the caller's cleanup kills it), then
# writes FILE, a configuration of the Blue Marble and "monthly", that upstream's PNG layer on
# 36-degree tiles of 64 pixels with a time for each month of 2024-01-01/2024-04-01.
time_upstream_config() {
  python3 "$here/time_upstream.py" "$work/port" "$work/upstream.log" &
  upstream_pid=$!
  for _ in $(seq 100); do [ -s "$work/port" ] && break; sleep 0.1; done
  [ -s "$work/port" ] || fail "the upstream did not start"
  cat >"$1" <<YAML
data_dir: $data
cache: {root: $work/cache}
upstreams:
  - {name: local, type: local, path: bmng_2048x1024.jpg}
  - {name: months, type: wms, url: "http://127.0.0.1:$(cat "$work/port")/wms", version: 1.1.1, crs: "EPSG:4326"}
layers:
  - {name: bluemarble, upstream: local, format: image/jpeg, grid: {levels: 3}}
  - name: monthly
    upstream: months
    format: image/png
    grid: {level_zero_delta: 36, tile_size: 64, levels: 2}
    time: {period: 2024-01-01/2024-04-01/P1M}
YAML
}

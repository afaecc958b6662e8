#!/usr/bin/env bash
# Varnish on loopback in front of a backend, for tests and benchmarks (docs/design/cdn.md):
#   varnish.sh start WORKDIR BACKEND_PORT   starts varnishd (Debian's varnish 7.1, vmod_xkey from
#                                           varnish-modules) with config/examples/varnish.vcl,
#                                           its backend's port written in, on a free port of
#                                           127.0.0.1, its own work dir (-n WORKDIR/n); prints
#                                           the port once it answers
#   varnish.sh stop WORKDIR                 stops it (its pid from WORKDIR/varnishd.pid)
# As root (CI) varnishd's workers drop to Debian's `varnish`/`vcache` users (-j unix): the work
# dir is made readable to them. Exits 77 (skip) when varnishd or vmod_xkey is not installed.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)
cmd=${1:-}
work=${2:-}
[ -n "$cmd" ] && [ -n "$work" ] || { echo "usage: varnish.sh start|stop WORKDIR [BACKEND_PORT]" >&2; exit 2; }

free_port() {
  python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()'
}

case $cmd in
start)
  backend=${3:?backend port}
  command -v varnishd >/dev/null || { echo "varnishd not installed (apt-get install varnish)" >&2; exit 77; }
  vmods=$(dirname "$(find /usr/lib -name libvmod_xkey.so 2>/dev/null | head -n 1)" 2>/dev/null || true)
  [ -n "$vmods" ] && [ -f "$vmods/libvmod_xkey.so" ] ||
    { echo "vmod_xkey not installed (apt-get install varnish-modules)" >&2; exit 77; }
  mkdir -p "$work"
  sed "s/\.port = \"8080\";/.port = \"$backend\";/" "$src/config/examples/varnish.vcl" >"$work/tellus.vcl"
  chmod 755 "$work"
  chmod 644 "$work/tellus.vcl"
  jail=()
  if [ "$(id -u)" != 0 ]; then jail=(-j none); fi
  # A port picked then bound by varnishd: another process may take it in between; retried.
  for _ in 1 2 3 4 5; do
    port=$(free_port)
    rm -f "$work/varnishd.pid"
    if varnishd "${jail[@]}" -n "$work/n" -a "127.0.0.1:$port" -f "$work/tellus.vcl" \
      -P "$work/varnishd.pid" -s malloc,64m -T 127.0.0.1:0 \
      -p vcc_allow_inline_c=off -p feature=+http2 >"$work/varnishd.log" 2>&1; then
      for _ in $(seq 100); do
        if curl -s -o /dev/null "http://127.0.0.1:$port/varnish-probe" 2>/dev/null; then
          echo "$port"
          exit 0
        fi
        sleep 0.1
      done
    fi
    [ -f "$work/varnishd.pid" ] && kill "$(cat "$work/varnishd.pid")" 2>/dev/null || true
  done
  echo "varnishd did not start: $(cat "$work/varnishd.log")" >&2
  exit 1
  ;;
stop)
  if [ -f "$work/varnishd.pid" ]; then
    pid=$(cat "$work/varnishd.pid")
    kill "$pid" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    rm -f "$work/varnishd.pid"
  fi
  ;;
*)
  echo "usage: varnish.sh start|stop WORKDIR [BACKEND_PORT]" >&2
  exit 2
  ;;
esac

#!/usr/bin/env bash
# A throwaway PostgreSQL 15 on loopback for tests (issue 27), from Debian's postgresql-15.
#
#   postgres.sh start DIR   initdb in DIR (created; must not hold a cluster), start the server on a
#                           free loopback port with its unix socket in DIR, print the connection
#                           URI on stdout (also written to DIR/uri). Takes ~1-2 s.
#   postgres.sh stop DIR    stop the server (fast shutdown) and remove DIR.
#   postgres.sh pause DIR   stop the server, keeping its data (a database that went away);
#   postgres.sh resume DIR  start it again on the same port (the same URI).
#
# fsync, synchronous_commit and full_page_writes are off: a test server's data may be lost in a
# crash, its speed may not. PostgreSQL refuses to run as root (CI is root): as root the cluster
# belongs to an unprivileged user, `tellus-test`, created if missing. Trust authentication on
# loopback and the socket only; the cluster's superuser is `tellus`.
set -euo pipefail

PG_BIN=${PG_BIN:-/usr/lib/postgresql/15/bin}
RUN_AS=tellus-test

die() { echo "postgres.sh: $*" >&2; exit 1; }

as_owner() {
  if [ "$(id -u)" -eq 0 ]; then
    runuser -u "$RUN_AS" -- "$@"
  else
    "$@"
  fi
}

free_port() {
  python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

start() {
  local dir=$1
  [ -x "$PG_BIN/initdb" ] || die "no $PG_BIN/initdb: install postgresql-15 (tools/debian-packages.txt)"
  [ ! -e "$dir/data" ] || die "$dir already holds a cluster"
  mkdir -p "$dir"
  if [ "$(id -u)" -eq 0 ]; then
    id "$RUN_AS" >/dev/null 2>&1 || useradd --system --no-create-home --shell /usr/sbin/nologin "$RUN_AS"
    chown "$RUN_AS" "$dir"
    # The owner walks to DIR through its parents.
    local p=$dir
    while [ "$p" != / ]; do p=$(dirname "$p"); chmod o+x "$p" 2>/dev/null || true; done
  fi
  as_owner "$PG_BIN/initdb" -D "$dir/data" -U tellus --auth=trust --no-sync -E UTF8 --locale=C.UTF-8 \
    >"$dir/initdb.log" 2>&1 || { cat "$dir/initdb.log" >&2; die "initdb failed"; }
  local port tries=0
  while :; do
    port=$(free_port)
    echo "-c listen_addresses=127.0.0.1 -p $port -c unix_socket_directories=$dir \
          -c fsync=off -c synchronous_commit=off -c full_page_writes=off \
          -c max_connections=400 -c shared_buffers=64MB" >"$dir/options"
    if as_owner "$PG_BIN/pg_ctl" -D "$dir/data" -l "$dir/server.log" -w -t 30 \
         -o "$(cat "$dir/options")" start >/dev/null; then
      break
    fi
    tries=$((tries + 1))
    [ $tries -lt 3 ] || { cat "$dir/server.log" >&2; die "the server did not start"; }
  done
  local uri="postgresql://tellus@127.0.0.1:$port/postgres"
  echo "$uri" >"$dir/uri"
  echo "$uri"
}

stop() {
  local dir=$1
  if [ -f "$dir/data/postmaster.pid" ]; then
    as_owner "$PG_BIN/pg_ctl" -D "$dir/data" -m fast -w stop >/dev/null 2>&1 || true
  fi
  rm -rf "$dir"
}

pause() {
  as_owner "$PG_BIN/pg_ctl" -D "$1/data" -m fast -w stop >/dev/null
}

resume() {
  as_owner "$PG_BIN/pg_ctl" -D "$1/data" -l "$1/server.log" -w -t 30 -o "$(cat "$1/options")" \
    start >/dev/null
}

case "${1:-}" in
  start) [ $# -eq 2 ] || die "usage: postgres.sh start DIR"; start "$(realpath -m "$2")" ;;
  stop) [ $# -eq 2 ] || die "usage: postgres.sh stop DIR"; stop "$(realpath -m "$2")" ;;
  pause) [ $# -eq 2 ] || die "usage: postgres.sh pause DIR"; pause "$(realpath -m "$2")" ;;
  resume) [ $# -eq 2 ] || die "usage: postgres.sh resume DIR"; resume "$(realpath -m "$2")" ;;
  *) die "usage: postgres.sh start|stop|pause|resume DIR" ;;
esac

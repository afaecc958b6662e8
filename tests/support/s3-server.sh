#!/usr/bin/env bash
# A real S3 server on loopback for tests (issue 27): OpenStack Swift from Debian 12's packages
# (swift-proxy, swift-object, swift-container, swift-account) with its s3api middleware and
# tempauth, one replica, rings built in the folder, every server on a free loopback port.
#
#   s3-server.sh start DIR   starts it under DIR (created; tile data in DIR/srv, which needs
#                            xattrs: ext4, xfs and tmpfs have them), creates the bucket, writes
#                            DIR/s3.env (S3_ENDPOINT, S3_REGION, S3_BUCKET, AWS_ACCESS_KEY_ID,
#                            AWS_SECRET_ACCESS_KEY, S3_PIDS) and prints it; exits once it answers
#   s3-server.sh stop DIR    stops the servers that DIR/s3.env names (by pid) and removes DIR
#   s3-server.sh pause DIR   kills (-9) the S3 front (swift-proxy-server), keeping the data: the
#                            object store gone under load
#   s3-server.sh resume DIR  starts the front again on the same port; exits once it answers
#
# Run as root (CI), the servers drop to the `swift` user the packages create (or `tellus-test`,
# created if missing). The credentials are fixed test ones; nothing here is for production.
set -euo pipefail

cmd=${1:-}
dir=${2:-}
[[ -n $cmd && -n $dir ]] || { echo "usage: $0 start|stop|pause|resume DIR" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)

if [[ $cmd == pause || $cmd == resume ]]; then
  # shellcheck disable=SC1091
  . "$dir/s3.env"
  read -r -a all <<<"$S3_PIDS"
  proxy=${all[3]}
  if [[ $cmd == pause ]]; then
    kill -9 "$proxy" 2>/dev/null || true
    exit 0
  fi
  PYTHONPATH=$here swift-proxy-server "$dir/etc/proxy-server.conf" -v >>"$dir/log/proxy.log" 2>&1 &
  sed -i "s/^S3_PIDS=.*/S3_PIDS=\"${all[0]} ${all[1]} ${all[2]} $!\"/" "$dir/s3.env"
  code=$(/usr/bin/python3 "$here/s3_server_helper.py" bucket "$S3_ENDPOINT" "$S3_BUCKET" \
    "$AWS_ACCESS_KEY_ID" "$AWS_SECRET_ACCESS_KEY" "$S3_REGION") || true
  [[ $code == 200 || $code == 409 ]] || { echo "s3-server: not back (HTTP $code)" >&2; exit 1; }
  exit 0
fi

if [[ $cmd == stop ]]; then
  if [[ -f $dir/s3.env ]]; then
    # shellcheck disable=SC1091
    . "$dir/s3.env"
    for p in $S3_PIDS; do kill "$p" 2>/dev/null || true; done
    for p in $S3_PIDS; do
      # Gone, or a zombie (an orphan whose reaper is slow; a container's init may never reap).
      for _ in $(seq 50); do
        [[ -r /proc/$p/stat && $(cut -d' ' -f3 "/proc/$p/stat" 2>/dev/null) != Z ]] || break
        sleep 0.1
      done
      kill -9 "$p" 2>/dev/null || true
    done
  fi
  rm -rf "$dir"
  exit 0
fi
[[ $cmd == start ]] || { echo "unknown command: $cmd" >&2; exit 2; }
for b in swift-proxy-server swift-object-server swift-container-server swift-account-server \
  swift-ring-builder; do
  command -v "$b" >/dev/null || {
    echo "$b missing: apt-get install swift-proxy swift-object swift-container swift-account" >&2
    exit 3
  }
done

start_ns=$(date +%s%N)
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$dir/srv/d1" "$dir/etc" "$dir/log" "$dir/run"
dir=$(cd "$dir" && pwd)
user=$(id -un)
if [[ $(id -u) == 0 ]]; then
  if id swift >/dev/null 2>&1; then user=swift
  else
    id tellus-test >/dev/null 2>&1 || useradd --system --no-create-home tellus-test
    user=tellus-test
  fi
  chown -R "$user" "$dir/srv" "$dir/run" "$dir/log"
  chmod 755 "$dir"
fi

etc=$dir/etc
cat >"$etc/swift.conf" <<EOF
[swift-hash]
swift_hash_path_suffix = tellus-test
swift_hash_path_prefix = tellus-test
[storage-policy:0]
name = Policy-0
default = yes
EOF

common() { # $1 port
  cat <<EOF
[DEFAULT]
bind_ip = 127.0.0.1
bind_port = $1
bind_timeout = 2
workers = 0
user = $user
swift_dir = $etc
devices = $dir/srv
mount_check = false
log_name = swift
log_udp_host = 127.0.0.1
log_udp_port = 9
EOF
}

fail() {
  echo "s3-server: $1" >&2
  tail -n 20 "$dir"/log/*.log >&2 || true
  [[ -n ${S3_KEEP:-} ]] || "$0" stop "$dir"
  exit 1
}

# One try: four free loopback ports (bound to port 0, read back, released: another process
# starting beside this one may take one first; a server that cannot bind its port within
# bind_timeout exits, and the try fails early), their configurations and rings, the servers, each
# seen listening on its own port, then the bucket created through S3.
# Sets code: the bucket's HTTP status (200 or 409: made), else why not.
try_start() {
  read -r p_proxy p_obj p_cont p_acct < <(/usr/bin/python3 - <<'EOF'
import socket
socks = [socket.socket() for _ in range(4)]
for s in socks:
    s.bind(("127.0.0.1", 0))
print(*[s.getsockname()[1] for s in socks])
EOF
  )
  for kind in object container account; do
    case $kind in object) port=$p_obj ;; container) port=$p_cont ;; account) port=$p_acct ;; esac
    {
      common "$port"
      printf '[pipeline:main]\npipeline = %s-server\n' "$kind"
      printf '[app:%s-server]\nuse = egg:swift#%s\n' "$kind" "$kind"
    } >"$etc/$kind-server.conf"
  done
  /usr/bin/python3 "$here/s3_server_helper.py" rings "$etc" "$p_obj" "$p_cont" "$p_acct"
  {
    common "$p_proxy"
    cat <<'EOF'
[pipeline:main]
pipeline = catch_errors proxy-logging cache s3api tempauth proxy-logging proxy-server
[app:proxy-server]
use = egg:swift#proxy
account_autocreate = true
[filter:catch_errors]
use = egg:swift#catch_errors
[filter:cache]
paste.filter_factory = tellus_swift_cache:filter_factory
[filter:proxy-logging]
use = egg:swift#proxy_logging
[filter:s3api]
use = egg:swift#s3api
location = us-east-1
force_swift_request_proxy_log = false
[filter:tempauth]
use = egg:swift#tempauth
user_tellus_s3 = tellus-test-secret .admin
EOF
  } >"$etc/proxy-server.conf"

  [[ $user == "$(id -un)" ]] || chown -R "$user" "$etc"
  pids=""
  local listeners=""
  for kind in object container account proxy; do
    PYTHONPATH=$here "swift-$kind-server" "$etc/$kind-server.conf" -v >>"$dir/log/$kind.log" 2>&1 &
    pids="$pids $!"
    case $kind in
      object) listeners="$listeners $!:$p_obj" ;; container) listeners="$listeners $!:$p_cont" ;;
      account) listeners="$listeners $!:$p_acct" ;; proxy) listeners="$listeners $!:$p_proxy" ;;
    esac
  done
  pids=${pids# }

  endpoint=http://127.0.0.1:$p_proxy
  cat >"$dir/s3.env" <<EOF
S3_ENDPOINT=$endpoint
S3_REGION=us-east-1
S3_BUCKET=tellus
AWS_ACCESS_KEY_ID=tellus:s3
AWS_SECRET_ACCESS_KEY=tellus-test-secret
S3_PIDS="$pids"
EOF
  # Every server listening on its own port (the bucket needs the proxy, account and container
  # servers only: an object server whose port was taken would fail every object later).
  code=$(/usr/bin/python3 "$here/s3_server_helper.py" listening 45 "$listeners") || true
  [[ $code == yes ]] || return 0
  code=$(/usr/bin/python3 "$here/s3_server_helper.py" bucket "$endpoint" tellus tellus:s3 \
    tellus-test-secret us-east-1 45 "$pids") || true
}

# Three tries, each on fresh ports; the servers of a failed one are stopped (the data folder
# kept: it is empty until the bucket exists).
code=none
for try in 1 2 3; do
  try_start
  [[ $code == 200 || $code == 409 ]] && break
  echo "s3-server: try $try on port $p_proxy failed ($code); the logs:" >&2
  tail -n 5 "$dir"/log/*.log >&2 || true
  for p in $pids; do kill -9 "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
done
[[ $code == 200 || $code == 409 ]] || fail "could not create the bucket on $endpoint (HTTP $code)"

ms=$((($(date +%s%N) - start_ns) / 1000000))
echo "S3_START_MS=$ms" >>"$dir/s3.env"
cat "$dir/s3.env"

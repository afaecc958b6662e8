#!/usr/bin/env bash
# Every command refuses an unknown or misspelt option with a usage error (exit 2) and a
# suggestion, before it does anything (issue 21: `cache prune --layr fake` pruned every layer,
# `seed --lvels 0-0` seeded the default levels, `serve --no-such-flag 1` started).
set -euo pipefail
tellus=$1
work=$(mktemp -d "${TMPDIR:-/tmp}/tellus-options.XXXXXX")
trap 'rm -rf "$work"' EXIT
cache="$work/cache"
fail() { echo "FAIL: $*" >&2; exit 1; }

# refused WANT ARGS...: exit 2, the message on stderr, nothing on stdout.
refused() {
  local want=$1
  shift
  set +e
  timeout 20 "$tellus" "$@" >"$work/out.txt" 2>"$work/err.txt"
  local rc=$?
  set -e
  [ $rc -eq 2 ] || fail "exit $rc (want 2) for: $* ($(cat "$work/err.txt"))"
  grep -qF -- "$want" "$work/err.txt" || fail "message for $*: $(cat "$work/err.txt")"
  [ ! -s "$work/out.txt" ] || fail "output for $*: $(cat "$work/out.txt")"
}

"$tellus" seed --cache "$cache" --layer bluemarble --levels 0-0 >/dev/null
tiles() { "$tellus" cache stats --json --cache "$cache" | python3 -c 'import json,sys; print(json.load(sys.stdin)["tiles"])'; }
[ "$(tiles)" = 50 ] || fail "seeded $(tiles) tiles, want 50"

refused "unknown option --layr (did you mean --layer?)" \
  cache prune --cache "$cache" --layr fake --older-than 0s --include-pinned
[ "$(tiles)" = 50 ] || fail "a refused prune removed tiles"
refused "unknown option --lvels (did you mean --levels?)" seed --cache "$cache" --lvels 1-1
[ "$(tiles)" = 50 ] || fail "a refused seed wrote tiles"
refused "unknown option --no-such-flag" serve --cache "$cache" --no-such-flag 1 --listen 127.0.0.1:0
refused "unknown option --json2 (did you mean --json?)" cache stats --cache "$cache" --json2
refused "--json is not an option of cache prune" cache prune --cache "$cache" --older-than 1d --json
refused "unknown subcommand 'prnue' (did you mean prune?)" cache prnue --cache "$cache"
refused "--dry-run takes no value" seed --cache "$cache" --dry-run=yes
refused "--levels is given more than once" seed --cache "$cache" --levels 0-0 --levels 1-1
refused "unexpected argument 'extra'" seed --cache "$cache" extra
refused "unknown option --camra (did you mean --camera?)" render --cache "$cache" --camra 0,0,1e7 --out "$work/x.png"
refused "unknown option --siz (did you mean --size?)" view --cache "$cache" --siz 10x10
refused "unknown option --latt (did you mean --lat?)" height --cache "$cache" --latt 1 --lon 2
# --bodies (the scene's other bodies, issue 26) means nothing to height: refused, not ignored.
refused "unknown option --bodies" height --cache "$cache" --lat 1 --lon 2 --bodies moon
refused "unknown option -layer (did you mean --layer?)" seed --cache "$cache" -layer bluemarble
refused "unknown command 'sede'" sede

# prune names a layer nobody knows: refused, nothing removed.
refused "no layer 'fake' in the configuration or the cache" \
  cache prune --cache "$cache" --layer fake --older-than 0s --include-pinned
# Without --layer, prune says it takes every layer, and how much, before it does; --dry-run stops there.
out=$("$tellus" cache prune --cache "$cache" --older-than 0s --include-pinned --dry-run)
echo "$out" | grep -q "would remove tiles fetched more than 0s ago from EVERY layer (pinned ones too): 50 tiles" ||
  fail "prune --dry-run: $out"
echo "$out" | grep -q "local/bluemarble: 50 tiles" || fail "prune --dry-run lists the layers: $out"
[ "$(tiles)" = 50 ] || fail "prune --dry-run removed tiles"
out=$("$tellus" cache prune --cache "$cache" --older-than 0s --include-pinned)
echo "$out" | grep -q "removing tiles fetched more than 0s ago from EVERY layer (pinned ones too): 50 tiles" ||
  fail "prune: $out"
echo "$out" | grep -q "pruned 50 tiles" || fail "prune: $out"
[ "$(tiles)" = 0 ] || fail "prune left $(tiles) tiles"

# --help anywhere prints the usage and exits 0.
# (into a file: with a pipe, grep -q leaves at the first line and a usage text longer than
# stdio's 4 KiB buffer would meet a closed pipe, SIGPIPE, under pipefail)
"$tellus" seed --help >"$work/help.txt" || fail "seed --help: exit $?"
grep -q "usage: tellus" "$work/help.txt" || fail "seed --help"
echo "options: ok"

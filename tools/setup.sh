#!/usr/bin/env bash
# Installs the Debian 12 packages tellus needs (tools/debian-packages.txt), only when one is missing,
# so that a second run costs a second. As root, or through sudo when not root.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
mapfile -t wanted < <(grep -vE '^\s*(#|$)' "$here/debian-packages.txt")
# Also "there": a name an installed package provides (NodeSource's nodejs provides and conflicts
# with npm, so asking apt for Debian's npm there would fail).
provided=" $(dpkg-query -W -f='${db:Status-Abbrev} ${Provides}\n' 2>/dev/null | awk '$1 == "ii" { $1 = ""; print }' \
  | tr ',' '\n' | awk '{ print $1 }' | tr '\n' ' ') "
missing=()
for p in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' && continue
  [[ $provided == *" $p "* ]] && continue
  missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "tellus setup: installing ${missing[*]}"
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"

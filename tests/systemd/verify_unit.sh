#!/usr/bin/env bash
# Installs the build with DESTDIR into a temporary root and checks what landed there: every file,
# `systemd-analyze verify` silent on the unit, a MemoryMax= set, systemd-sysusers making the cmmd user, the unit's
# `systemd-analyze security` exposure at or under the ceiling with no item failed but the accepted
# ones, and a reinstall keeping the config. Needs no running systemd.
# Usage: verify_unit.sh CMAKE BUILD_DIR UNIT SYSUSERS_CONF [OTHER_INSTALLED_FILE...]
# (paths as installed, without DESTDIR).
set -euo pipefail

cmake=$1 build=$2 unit=$3 sysusers=$4
shift 4
# systemd 252's figure for the unit (docs/systemd.md, Exposure). The items it still fails, each
# for a reason given there; any other ✗ means a hardening line was lost, even one too light to
# move the rounded figure.
max_exposure=1.3
accepted_failures=(
  PrivateNetwork= IPAddressDeny= PrivateDevices= DeviceAllow= SupplementaryGroups= UMask=
  'RestrictAddressFamilies=~AF_(INET|INET6)' 'RestrictAddressFamilies=~AF_UNIX' RootDirectory=/RootImage=
)
fail() { echo "verify_unit: $*" >&2; exit 1; }

root=$(mktemp -d "${TMPDIR:-/tmp}/cmmd-root.XXXXXX")
trap 'rm -rf "$root"' EXIT

out=$(DESTDIR="$root" "$cmake" --install "$build" 2>&1) || { echo "$out"; fail "cmake --install $build failed"; }
exec_start=$(sed -n 's/^ExecStart=\([^ ]*\).*/\1/p' "$root$unit" 2>/dev/null || true)
[ -n "$exec_start" ] || fail "no ExecStart= in $root$unit"
config=$(sed -n 's/^ExecStart=.* --config \([^ ]*\).*/\1/p' "$root$unit")
[ -n "$config" ] || fail "ExecStart= in $unit names no --config"
for f in "$unit" "$sysusers" "$exec_start" "$config" "$@"; do
  [ -e "$root$f" ] || fail "cmake --install did not install $f (looked in $root$f)"
done
[ -x "$root$exec_start" ] || fail "$exec_start is not executable"
# A runaway must hit cmmd's own memory cap, never the host's (docs/systemd.md, Memory).
grep -Eq '^MemoryMax=[0-9]+[KMGT]?$' "$root$unit" || fail "$unit sets no MemoryMax= (docs/systemd.md, Memory)"

# verify --root resolves every path inside the root, so the root gets what a real system has:
# the targets a service's default dependencies name, and the system programs (kill) the unit
# runs. The programs we install must already be there (checked above), never copied from the host.
host_units=""
for d in /usr/lib/systemd/system /lib/systemd/system; do
  [ -e "$d/sysinit.target" ] && { host_units=$d; break; }
done
[ -n "$host_units" ] || fail "no systemd units on this machine (install the systemd package)"
mkdir -p "$root/usr/lib/systemd/system"
for t in sysinit.target basic.target shutdown.target; do
  cp "$host_units/$t" "$root/usr/lib/systemd/system/"
done
for program in $(sed -n 's/^Exec[A-Za-z]*=[-@:+!]*\([^ ]*\).*/\1/p' "$root$unit"); do
  if [ ! -e "$root$program" ]; then
    [ -x "$program" ] || fail "$unit runs $program, which neither the install nor this machine has"
    mkdir -p "$root$(dirname "$program")"
    cp -L "$program" "$root$program"
  fi
done

# verify exits 0 on warnings, so any output at all is a failure.
out=$(systemd-analyze verify --root="$root" "$root$unit" 2>&1) || { echo "$out"; fail "systemd-analyze verify failed"; }
[ -z "$out" ] || { echo "$out"; fail "systemd-analyze verify is not silent on $unit"; }

mkdir -p "$root/etc"
out=$(systemd-sysusers --root="$root" "$root$sysusers" 2>&1) || { echo "$out"; fail "systemd-sysusers failed on $sysusers"; }
grep -q '^cmmd:x:[0-9]*:[0-9]*:[^:]*:/var/lib/cmmd:[^:]*nologin$' "$root/etc/passwd" \
  || { echo "$out"; cat "$root/etc/passwd"; fail "systemd-sysusers made no cmmd user from $sysusers"; }
grep -q '^cmmd:x:' "$root/etc/group" || fail "systemd-sysusers made no cmmd group from $sysusers"

report=$(systemd-analyze security --offline=yes --root="$root" "$root$unit" 2>"$root/security.err") \
  || { echo "$report"; cat "$root/security.err"; fail "systemd-analyze security failed"; }
[ ! -s "$root/security.err" ] || { cat "$root/security.err"; fail "systemd-analyze security complained"; }
exposure=$(sed -n 's/.*Overall exposure level for [^:]*: \([0-9.]*\).*/\1/p' <<<"$report")
[ -n "$exposure" ] || { echo "$report"; fail "no overall exposure in systemd-analyze security's report"; }
echo "$report" | grep -v '^✓'
while read -r item; do
  printf '%s\n' "${accepted_failures[@]}" | grep -qxF -- "$item" || fail "systemd-analyze security fails $item"
done < <(sed -n 's/^✗ \([^ ]*\) .*/\1/p' <<<"$report")
if awk -v e="$exposure" -v m="$max_exposure" 'BEGIN { exit !(e > m) }'; then
  fail "exposure $exposure is over the ceiling $max_exposure"
fi
# A reinstall keeps the site's config.
echo '{"site": "edited"}' >"$root$config"
out=$(DESTDIR="$root" "$cmake" --install "$build" 2>&1) || { echo "$out"; fail "second cmake --install failed"; }
[ "$(cat "$root$config")" = '{"site": "edited"}' ] || fail "a reinstall overwrote the site's $config"

echo "verify_unit: verify silent, cmmd user made, exposure $exposure (ceiling $max_exposure)"

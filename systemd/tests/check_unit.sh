#!/usr/bin/env bash
# Checks the installed form of rsriod.service with systemd's own tools (no running systemd needed):
#  verify: must print nothing at all (unknown keys and bad values only warn, with exit code 0,
#          reference/runtime.md Sec. 4.3, so any output is a failure);
#  security --offline: the exposure score must stay at or below the threshold given.
# usage: check_unit.sh UNIT_FILE THRESHOLD  (threshold in tenths of the score, as --threshold takes it)
set -euo pipefail
unit=$1 threshold=$2
command -v systemd-analyze >/dev/null || { echo "systemd-analyze is not installed (package systemd)"; exit 1; }
out=$(systemd-analyze verify --man=no "$unit" 2>&1) || { echo "verify failed:"; echo "$out"; exit 1; }
if [ -n "$out" ]; then echo "verify printed (must print nothing):"; echo "$out"; exit 1; fi
echo "systemd-analyze verify: clean"
sec=$(systemd-analyze security --offline=yes --threshold="$threshold" "$unit" 2>&1) && rc=0 || rc=$?
echo "$sec" | tail -n 1
if [ "$rc" -ne 0 ]; then echo "$sec" | grep -E '✗' | head -n 40; echo "exposure above $threshold"; exit 1; fi

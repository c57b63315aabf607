#!/usr/bin/env bash
# rsriod under faults, against the board emulator over real UDP and DDS (separate processes):
#  1. light packet loss (0.05 %: about one xWR1843 frame in four loses a packet): damaged frames are
#     counted, flagged and skipped, the good ones give poses;
#  2. the IMU topic silent for 2 s while the radar streams: the status says "imu stale", then "imu
#     ok" again, and poses keep coming after the IMU is back;
#  3. the board emulator killed (radar unplugged): the status says the radar is stale and the IMU
#     (which came with the board) stale too, within the timeouts;
#  4. the emulator back with 10 % packet loss (every frame damaged): the daemon reconnects by itself,
#     streams again, and its status says that the frames are damaged;
#  5. SIGTERM: exit 0.
# Addresses of its own (127.0.0.5 board, 127.0.0.6 host) so that it can run beside other tests.
# usage: daemon_faults.sh BIN_DIR OUT_DIR
# rsriod and rsrio-echo from BIN_DIR; the board emulator from RSRIO_HELPER_BIN_DIR when set (the
# sanitizer builds use the release build's: the board is not under test, and an instrumented one
# may not keep its 100 ms frame period on 2 cores).
set -euo pipefail
bin=$1 out=$2
helpers=${RSRIO_HELPER_BIN_DIR:-$bin}
[ -x "$helpers/rsrio-dca1000-emu" ] || { echo "FAIL: $helpers/rsrio-dca1000-emu missing (build the release preset first: ./rsrio build)"; exit 1; }
mkdir -p "$out"
domain=$((200 + $$ % 30))   # this test's range of domains (daemon_end_to_end.sh lists them)
pids=()
cleanup() { for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done; }
trap cleanup EXIT
fail() { echo "FAIL: $*"; for f in "$out"/*.log; do echo "--- $f"; tail -n 25 "$f"; done; exit 1; }
status_has() { grep -q "$1" "$out/echo.log"; }
wait_for() { # pattern seconds
  local i
  for ((i = 0; i < $2 * 10; i++)); do status_has "$1" && return 0; sleep 0.1; done
  return 1
}
emulator() { # log loss [emulator options...]
  local log=$1 loss=$2; shift 2
  "$helpers/rsrio-dca1000-emu" --scenario scenarios/demo_meeting_room.yaml --address 127.0.0.5 --host-data 127.0.0.6:4098 \
    --loss "$loss" --seed 7 --once --imu-topic /imu --domain "$domain" "$@" >"$out/$log" 2>&1 &
  emu=$!
  pids+=($emu)
}

{
  printf 'daemon:\n  radar_source: "dca1000://127.0.0.5:127.0.0.6"\n  imu_source: dds\n  domain_id: %d\n' "$domain"
  printf '  radar_timeout_s: 1.0\n  imu_timeout_s: 0.5\n  status_period_s: 0.5\n'
  printf 'radar:\n  preset: xwr1843\n  frame_period_ms: 100.0\n'
  grep -v '^%YAML' config/rsrio.yaml | grep -v '^---'
} >"$out/rsriod.yaml"

"$bin/rsrio-echo" --domain "$domain" --quiet --status --tum "$out/echo.tum" >"$out/echo.log" 2>&1 &
pids+=($!)
"$bin/rsriod" --config "$out/rsriod.yaml" >"$out/rsriod.out" 2>"$out/rsriod.log" &
daemon=$!
pids+=($daemon)
sleep 1
emulator emulator1.log 0.0005 --imu-gap 6:2
wait_for "radar streaming imu ok" 30 || fail "the daemon never streamed"
# Line number of the first status matching $1 after line $2 (0: none yet).
line_after() { { tail -n +"$(($2 + 1))" "$out/echo.log" | grep -n "$1" || true; } | head -n 1 | cut -d: -f1 | awk -v b="$2" '{ print $1 + b }'; }
for ((i = 0; i < 200; i++)); do stale_at=$(line_after "radar streaming imu stale" 0); [ -n "$stale_at" ] && break; sleep 0.1; done
[ -n "$stale_at" ] || fail "the IMU went silent for 2 s, but the status never said 'imu stale' while the radar streamed"
for ((i = 0; i < 100; i++)); do back_at=$(line_after "radar streaming imu ok" "$stale_at"); [ -n "$back_at" ] && break; sleep 0.1; done
[ -n "$back_at" ] || fail "the IMU came back, but the status did not say 'imu ok' again"
poses_back=$(wc -l <"$out/echo.tum")
for ((i = 0; i < 100; i++)); do [ "$(wc -l <"$out/echo.tum")" -ge $((poses_back + 10)) ] && break; sleep 0.1; done
[ "$(wc -l <"$out/echo.tum")" -ge $((poses_back + 10)) ] || fail "no poses after the IMU came back ($poses_back before)"
kill -0 "$daemon" || fail "rsriod died when the IMU went silent"
echo "IMU silent 2 s: status 'imu stale' while the radar streamed, then 'imu ok'; poses resumed ($poses_back -> $(wc -l <"$out/echo.tum"))"
for ((i = 0; i < 300; i++)); do [ "$(wc -l <"$out/echo.tum")" -ge 30 ] && break; sleep 0.1; done
kill -9 "$emu"   # mid-walk: pull the plug
wait_for "radar stale" 10 || fail "no 'radar stale' in the status after the board went away"
wait_for "imu stale" 5 || fail "no 'imu stale' in the status after the IMU went silent"
frames=$(grep -o 'frames [0-9]*' "$out/echo.log" | tail -n 1 | cut -d' ' -f2)
damaged=$(grep -o 'damaged [0-9]*' "$out/echo.log" | tail -n 1 | cut -d' ' -f2)
poses_before=$(wc -l <"$out/echo.tum")
echo "light loss: $frames frames, $damaged damaged, $poses_before poses"
[ "${damaged:-0}" -gt 0 ] || fail "packet loss but no damaged frame in the status"
[ "$poses_before" -ge 30 ] || fail "only $poses_before poses before the unplug"
[ "$poses_before" -le $((frames - damaged)) ] || fail "$poses_before poses from $((frames - damaged)) good frames: damaged frames were used"
kill -0 "$daemon" || fail "rsriod died when the board went away"

lines_before=$(wc -l <"$out/echo.log")
emulator emulator2.log 0.1   # plugged in again, with heavy loss
for ((i = 0; i < 200; i++)); do
  tail -n +"$((lines_before + 1))" "$out/echo.log" | grep -q "radar streaming imu ok" && break
  sleep 0.1
done
[ "$i" -lt 200 ] || fail "the daemon did not stream again after the board came back"
for ((i = 0; i < 100; i++)); do
  tail -n +"$((lines_before + 1))" "$out/echo.log" | grep -q "frames damaged since the last status" && break
  sleep 0.1
done
[ "$i" -lt 100 ] || fail "10 % packet loss, but the status does not say that the frames are damaged"
poses_after=$(wc -l <"$out/echo.tum")
kill -0 "$daemon" || fail "rsriod died"
kill -TERM "$daemon"
rc=0; wait "$daemon" || rc=$?
[ "$rc" -eq 0 ] || fail "rsriod exited with $rc after SIGTERM"
echo "unplug: radar and IMU stale; replug with 10 % loss: streaming, damage reported; poses $poses_after; clean exit"
echo "PASS"

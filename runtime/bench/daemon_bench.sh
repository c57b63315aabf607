#!/usr/bin/env bash
# rsriod benchmark: the daemon with the BA backend on a simulated xWR1843 walk (laps of the demo's
# meeting room) replayed in real time from a recording, poses to rsrio-echo over DDS. Prints:
#   latency frame complete -> odometry published (p50 / p99 / max), the RIO thread's pickup delay
#   (its jitter: frame complete -> taken from the queue) and work per frame, BA per keyframe,
#   CPU use per thread and in total, the real-time factor (frame period / RIO work per frame) and
#   peak memory (VmHWM) over the run.
# usage: daemon_bench.sh BIN_DIR OUT_DIR [MINUTES]   (default 10: the issue's 10-minute run)
# The recording is made once per length and kept in OUT_DIR (~0.5 GB a minute).
set -euo pipefail
bin=$1 out=$2 minutes=${3:-10}
mkdir -p "$out"
laps=$(awk -v m="$minutes" 'BEGIN { n = int(m * 60 / 45 + 0.999); print (n < 1 ? 1 : n) }')
scenario=$out/walk_${laps}laps.yaml
rec=$out/walk_${laps}laps.mcap
domain=$((150 + ($$ + 60) % 80))

# The demo's walk, its waypoints (and pauses) repeated: one lap ends where it starts.
python3 - "$laps" scenarios/demo_meeting_room.yaml "$scenario" <<'PY'
import re, sys
laps, src, dst = int(sys.argv[1]), sys.argv[2], sys.argv[3]
text = open(src).read()
def grab(key):
    m = re.search(r"(  %s: \[)([^\]]*)\]" % key, text, re.S)
    return m, [v.strip() for v in m.group(2).replace("\n", " ").split(",")]
m, wp = grab("waypoints")
pts = list(zip(wp[0::2], wp[1::2]))
lap = pts[1:]                            # the first point is the start; the lap returns to it
text = text.replace(m.group(0), m.group(1) + ", ".join(f"{x}, {y}" for x, y in pts[:1] + lap * laps) + "]")
m, pauses = grab("pauses_s")
# pauses_s: one per waypoint (first and last 0 in the demo); keep the inner pauses on every lap
inner = pauses[1:-1] + ["1.0"]
text = text.replace(m.group(0), m.group(1) + ", ".join(["0.0"] + (inner * laps)[: len(lap) * laps - 1] + ["0.0"]) + "]")
text = re.sub(r"^name: .*$", f"name: bench_meeting_room_{laps}laps", text, flags=re.M)
open(dst, "w").write(text)
PY
if [ ! -s "$rec" ]; then
  echo "simulating $laps laps of the meeting room (~$minutes min of radar) into $rec ..." >&2
  "$bin/rsrio-sim" --scenario "$scenario" --out "$rec.part" >"$out/sim.log" 2>&1 || { tail "$out/sim.log"; exit 1; }
  mv "$rec.part" "$rec"
fi
{
  grep -v '^%YAML' config/rsrio.yaml | grep -v '^---'
  printf 'backend:\n  max_image_range_m: 8.0\n'
} >"$out/estimator.yaml"
{ printf 'daemon:\n  backend: ba\n  domain_id: %d\n  status_period_s: 1.0\n' "$domain"; cat "$out/estimator.yaml"; } \
  >"$out/rsriod.yaml"

"$bin/rsrio-echo" --domain "$domain" --quiet --status --pose-tum "$out/map.tum" --tum "$out/odom.tum" \
  >"$out/echo.log" 2>&1 &
echo_pid=$!
sleep 1
start=$(date +%s.%N)
"$bin/rsriod" --source "recording:$rec" --imu-source recording --config "$out/rsriod.yaml" \
  >"$out/rsriod.out" 2>"$out/rsriod.log" &
pid=$!
peak_rss=0
threads_cpu=""
while kill -0 "$pid" 2>/dev/null; do
  rss=$(awk '/^VmRSS/ { print $2 }' "/proc/$pid/status" 2>/dev/null || echo 0)
  [ "${rss:-0}" -gt "$peak_rss" ] && peak_rss=$rss
  # Per-thread CPU (utime + stime, clock ticks) as last seen: threads end at shutdown.
  snapshot=$(for t in /proc/"$pid"/task/*; do
               awk '{ sub(/^[0-9]+ \(/, ""); split($0, a, ") "); split(a[2], f, " "); print a[1], f[12] + f[13] }' "$t/stat" 2>/dev/null
             done || true)
  [ -n "$snapshot" ] && threads_cpu=$snapshot
  hwm=$(awk '/^VmHWM/ { print $2 }' "/proc/$pid/status" 2>/dev/null || true)
  [ -n "$hwm" ] && peak_hwm=$hwm
  total=$(awk '{ print $14 + $15 }' "/proc/$pid/stat" 2>/dev/null || true)
  [ -n "$total" ] && cpu_ticks=$total
  sleep 1
done
rc=0; wait "$pid" || rc=$?
end=$(date +%s.%N)
sleep 1
kill -INT "$echo_pid"; wait "$echo_pid" || true
[ "$rc" -eq 0 ] || { echo "rsriod exited with $rc"; tail -n 20 "$out/rsriod.log"; exit 1; }

hz=$(getconf CLK_TCK)
wall=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }')
pick() { grep "$1" "$out/rsriod.log" | tail -n 1 | sed -n "s/.*$2 \([0-9.]*\) ms.*/\1/p"; }
frames=$(grep -o ' frames [0-9]*' "$out/echo.log" | tail -n 1 | awk '{ print $2 }')
dropped=$(grep -o 'frames [0-9]* damaged [0-9]* dropped [0-9]*' "$out/echo.log" | tail -n 1 | awk '{ print $NF }')
kf_dropped=$(grep -o 'keyframes-queue drops [0-9]*' "$out/echo.log" | tail -n 1 | awk '{ print $NF }')
keyframes=$(grep -o 'keyframes [0-9]* gaussians' "$out/echo.log" | tail -n 1 | awk '{ print $2 }')
gaussians=$(grep -o 'gaussians [0-9]*' "$out/echo.log" | tail -n 1 | awk '{ print $2 }')
busy50=$(pick "RIO processing" p50)
echo
echo "rsriod benchmark: $minutes min walk ($laps laps, $frames frames at 10 Hz), backend ba, $(nproc) cores"
printf '| %-46s | %s |\n' "figure" "value" "---" "---"
printf '| %-46s | %s / %s / %s ms |\n' "latency frame complete -> published p50/p99/max" "$(pick 'latency frame' p50)" "$(pick 'latency frame' p99)" "$(pick 'latency frame' max)"
printf '| %-46s | %s / %s / %s ms |\n' "RIO pickup delay (jitter) p50/p99/max" "$(pick 'RIO pickup' p50)" "$(pick 'RIO pickup' p99)" "$(pick 'RIO pickup' max)"
printf '| %-46s | %s / %s ms |\n' "RIO work per frame p50/p99" "$busy50" "$(pick 'RIO processing' p99)"
printf '| %-46s | %s |\n' "real-time factor (100 ms / RIO work p50)" "$(awk -v b="$busy50" 'BEGIN { printf "%.1f x", 100 / b }')"
printf '| %-46s | %s / %s ms |\n' "BA per keyframe p50/p99" "$(pick 'bundle adjustment' p50)" "$(pick 'bundle adjustment' p99)"
printf '| %-46s | %s keyframes (%s dropped), %s Gaussians |\n' "backend" "${keyframes:-0}" "${kf_dropped:-0}" "${gaussians:-0}"
printf '| %-46s | %s |\n' "frames dropped (RIO behind)" "${dropped:-0}"
printf '| %-46s | %s |\n' "CPU total (of one core) over ${wall} s" "$(awk -v t="$cpu_ticks" -v h="$hz" -v w="$wall" 'BEGIN { printf "%.0f %%", 100 * t / h / w }')"
while read -r name ticks; do
  case "$name" in rsrio-*) printf '| %-46s | %s |\n' "  thread $name" "$(awk -v t="$ticks" -v h="$hz" -v w="$wall" 'BEGIN { printf "%.0f %%", 100 * t / h / w }')";; esac
done <<<"$threads_cpu"
printf '| %-46s | %s MB (RSS sampled: %s MB) |\n' "peak memory VmHWM" "$(awk -v k="${peak_hwm:-0}" 'BEGIN { printf "%.1f", k / 1024 }')" "$(awk -v k="$peak_rss" 'BEGIN { printf "%.1f", k / 1024 }')"
# Ground truth (and the frontend's replay for comparison) from the recording.
# Kept for the next run, made again when rsrio-replay is newer (it decides what ground_truth.tum holds).
gt=$out/replay_${laps}laps/ground_truth.tum
[ -s "$gt" ] && [ "$gt" -nt "$bin/rsrio-replay" ] || "$bin/rsrio-replay" --input "$rec" --out "$out/replay_${laps}laps" --config "$out/estimator.yaml" \
  >/dev/null 2>&1 || true
if [ -s "$gt" ]; then
  ape() { "$bin/rsrio-eval" --gt "$gt" --est "$1" 2>&1 | awk '/^APE translation \(m\)/ { print $5 }'; }
  printf '| %-46s | map %s m, odom %s m |\n' "APE translation RMSE (received over DDS)" "$(ape "$out/map.tum")" "$(ape "$out/odom.tum")"
fi

#!/usr/bin/env bash
# rsrio-replay --backend ba --pipelined: the backend on its own thread (the daemon's keyframe
# hand-over, waiting for a slot instead of dropping). It must optimise the same keyframes as the
# sequential replay (nothing dropped), publish a pose per frame that the backend corrects, stay
# accurate against the simulator's ground truth, and refuse --pipelined without a backend.
# Also under the thread sanitizer (label concurrency): the replay's two threads.
# Arguments: rsrio-replay [rsrio-sim rsrio-eval: from RSRIO_HELPER_BIN_DIR when set, else next to
# rsrio-replay; a sanitizer build takes them from the release build]
set -u
replay=$1
helpers=${RSRIO_HELPER_BIN_DIR:-$(dirname "$replay")}
sim=$helpers/rsrio-sim eval=$helpers/rsrio-eval
tmp=$(mktemp -d)
trap 'rm -rf -- "$tmp"' EXIT
fails=0
ok() { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
stat_of() { grep -o "\"$2\": [0-9.]*" "$1/stats.json" | head -n 1 | awk '{ print $2 }'; }
ape_of() { "$eval" --gt "$1/ground_truth.tum" --est "$1/$2" 2>&1 | awk '/^APE translation \(m\)/ { print $5 }'; }

"$sim" --scenario scenarios/test_tiny.yaml --out "$tmp/rec.mcap" --threads 1 > "$tmp/sim.log" 2>&1 \
  || { cat "$tmp/sim.log"; echo "FAIL simulate"; exit 1; }
# test_tiny's rig (the radar yawed 2 degrees) and a backend with a handful of keyframes.
sed 's/^  radar_rpy_deg: .*/  radar_rpy_deg: [0.0, 0.0, 2.0]/' config/rsrio.yaml > "$tmp/tiny_ba.yaml"
printf 'backend:\n  keyframe_distance_m: 0.5\n  keyframe_angle_deg: 90.0\n  keyframe_time_s: 10.0\n  first_keyframe_mapping_iterations: 10\n  max_image_range_m: 6.0\n' >> "$tmp/tiny_ba.yaml"

for mode in sequential pipelined; do
  flag=""; [ $mode = pipelined ] && flag=--pipelined
  if "$replay" --input "$tmp/rec.mcap" --out "$tmp/$mode" --config "$tmp/tiny_ba.yaml" --backend ba $flag --quiet \
       > "$tmp/$mode.log" 2>&1; then
    ok "$mode replay"
  else
    bad "$mode replay"; tail -n 20 "$tmp/$mode.log" | sed 's/^/    /'
  fi
done
grep -q '"pipelined": true' "$tmp/pipelined/stats.json" && ok "stats: pipelined" || bad "stats.json lacks pipelined: true"
grep -q '"pipelined": false' "$tmp/sequential/stats.json" && ok "stats: sequential" || bad "stats.json lacks pipelined: false"
# The frontend's waits for a free slot, summed (part of the pipelined per-frame time): none when
# sequential, between 0 and the wall time when pipelined.
w_seq=$(stat_of "$tmp/sequential" waited_for_backend_s) w_pipe=$(stat_of "$tmp/pipelined" waited_for_backend_s)
wall_pipe=$(stat_of "$tmp/pipelined" wall_seconds)
awk -v s="$w_seq" -v p="$w_pipe" -v w="$wall_pipe" 'BEGIN { exit !(s != "" && s == 0 && p != "" && w != "" && p >= 0 && p <= w) }' \
  && ok "stats: waited for the backend ${w_pipe} s of ${wall_pipe} s pipelined, ${w_seq} sequential" \
  || bad "stats: waited_for_backend_s pipelined '$w_pipe' (wall '$wall_pipe'), sequential '$w_seq'"
kf_seq=$(stat_of "$tmp/sequential" keyframes) kf_pipe=$(stat_of "$tmp/pipelined" keyframes)
[ -n "$kf_pipe" ] && [ "$kf_pipe" -ge 3 ] && [ "$kf_pipe" = "$kf_seq" ] \
  && ok "the same keyframes as the sequential replay ($kf_pipe): none dropped" \
  || bad "keyframes: pipelined '$kf_pipe', sequential '$kf_seq'"
for f in estimate.tum estimate_final.tum frontend.tum; do
  n=$(grep -c . "$tmp/pipelined/$f" 2>/dev/null)
  [ "$n" = 63 ] && ok "pipelined: $f, one pose per frame" || bad "pipelined: $f has '$n' lines, want 63"
done
cmp -s "$tmp/pipelined/frontend.tum" "$tmp/pipelined/estimate.tum" && bad "pipelined: the backend changed no pose" \
  || ok "pipelined: the backend corrects poses"
# The frontend does not depend on the backend's thread.
cmp -s "$tmp/pipelined/frontend.tum" "$tmp/sequential/frontend.tum" && ok "pipelined: the same frontend" \
  || bad "pipelined: the frontend differs from the sequential replay's"
for f in estimate.tum estimate_final.tum; do
  ape=$(ape_of "$tmp/pipelined" $f) ref=$(ape_of "$tmp/sequential" $f)
  awk -v a="$ape" 'BEGIN { exit !(a != "" && a < 0.1) }' && ok "pipelined $f: APE $ape m < 0.1 m (sequential $ref m)" \
    || bad "pipelined $f: APE '$ape' m (sequential '$ref')"
done
out=$("$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --pipelined 2>&1); rc=$?
[ $rc = 2 ] && grep -qF -- "--backend ba" <<<"$out" && ok "--pipelined without a backend: exit 2" \
  || bad "--pipelined without a backend: rc=$rc, $out"

echo "$fails failed"
[ "$fails" = 0 ]

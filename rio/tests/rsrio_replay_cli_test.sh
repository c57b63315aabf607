#!/usr/bin/env bash
# rsrio-replay and rsrio-eval end to end, as a person uses them: rsrio-sim makes test_tiny, the
# replay writes its files, its APE against the simulator's ground truth is bounded; a truncated
# recording is replayed up to the damage; bad usage and bad options give one clear message, exit 2.
# Arguments: rsrio-replay rsrio-sim rsrio-eval
set -u
replay=$1 sim=$2 eval=$3
tmp=$(mktemp -d)
trap 'rm -rf -- "$tmp"' EXIT
fails=0
ok() { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
check() { # name expected_rc expected_text program args...
  local name=$1 want_rc=$2 want=$3 out rc
  shift 3
  out=$("$@" 2>&1); rc=$?
  if [ "$rc" != "$want_rc" ] || ! grep -qF -- "$want" <<<"$out"; then
    bad "$name: rc=$rc (want $want_rc), output lacks '$want':"; echo "$out" | tail -n 20 | sed 's/^/    /'
  else
    ok "$name"
  fi
}
# test_tiny's rig: the radar is yawed 2 degrees on the rig.
sed 's/^  radar_rpy_deg: .*/  radar_rpy_deg: [0.0, 0.0, 2.0]/' config/rsrio.yaml > "$tmp/tiny.yaml"

check "simulate" 0 "wrote" "$sim" --scenario scenarios/test_tiny.yaml --out "$tmp/rec.mcap" --threads 1
check "replay" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/out" --config "$tmp/tiny.yaml"
for f in frontend.tum estimate.tum ground_truth.tum stats.json; do
  [ -s "$tmp/out/$f" ] && ok "wrote $f" || bad "missing $f"
done
[ "$(grep -c . "$tmp/out/frontend.tum")" = 63 ] && ok "one pose per frame" || bad "frontend.tum has $(grep -c . "$tmp/out/frontend.tum") lines, want 63"
# the truth at the frames' stamps (interpolated from the IMU-rate stream): exact pairs for evo too
cmp -s <(cut -d' ' -f1 "$tmp/out/frontend.tum") <(cut -d' ' -f1 "$tmp/out/ground_truth.tum") \
  && ok "ground truth at the frames' stamps" || bad "ground_truth.tum's stamps are not frontend.tum's"
cmp -s "$tmp/out/frontend.tum" "$tmp/out/estimate.tum" && ok "estimate = frontend without a backend" || bad "estimate.tum differs from frontend.tum"
grep -q '"frames": 63' "$tmp/out/stats.json" && ok "stats: frames" || bad "stats.json frames"
grep -q '"recording_damage": null' "$tmp/out/stats.json" && ok "stats: no damage" || bad "stats.json damage"
grep -q '"dsp": {"p50": ' "$tmp/out/stats.json" && ok "stats: timings" || bad "stats.json timings"
# APE against the simulator's ground truth (3.5 m walk): a few centimetres.
out=$("$eval" --gt "$tmp/out/ground_truth.tum" --est "$tmp/out/frontend.tum" 2>&1)
ape=$(awk '/^APE translation \(m\)/ { print $5 }' <<<"$out")
awk -v a="$ape" 'BEGIN { exit !(a != "" && a < 0.05) }' && ok "APE $ape m < 0.05 m" || { bad "APE '$ape' m"; echo "$out"; }

# a recording cut in the middle: replayed up to the damage, said so, exit 0
size=$(stat -c %s "$tmp/rec.mcap")
head -c $((size / 2)) "$tmp/rec.mcap" > "$tmp/cut.mcap"
check "truncated recording" 0 "replayed up to the damage" "$replay" --input "$tmp/cut.mcap" --out "$tmp/cut" --config "$tmp/tiny.yaml"
grep -q '"recording_damage": "' "$tmp/cut/stats.json" && ok "stats: damage reported" || bad "stats.json lacks the damage"
n=$(grep -c . "$tmp/cut/frontend.tum")
[ "$n" -gt 10 ] && [ "$n" -lt 63 ] && ok "truncated: $n poses" || bad "truncated: $n poses"

# --odometry-drift: the frontend's poses as a drifting frontend gives them. Every step 10 % long
# makes the path 1.1 times as long; 2 deg/s turns the last pose by 2 deg/s times the time since
# the first (to the yaw's rounding), and the first pose is the frontend's.
path_length() { awk 'NR > 1 { d += sqrt(($2 - x)^2 + ($3 - y)^2 + ($4 - z)^2) } { x = $2; y = $3; z = $4 } END { printf "%.6f", d }' "$1"; }
last_yaw_deg() { tail -n 1 "$1" | awk '{ printf "%.6f", atan2(2 * ($8 * $7 + $5 * $6), 1 - 2 * ($6 * $6 + $7 * $7)) * 45 / atan2(1, 1) }'; }
check "drift scale" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/long" --config "$tmp/tiny.yaml" --odometry-drift 0,0.1
awk -v a="$(path_length "$tmp/long/frontend.tum")" -v b="$(path_length "$tmp/out/frontend.tum")" \
  'BEGIN { exit !(b > 1 && a / b > 1.0999 && a / b < 1.1001) }' && ok "drift: every step 10 % long" \
  || bad "drift: path $(path_length "$tmp/long/frontend.tum") against $(path_length "$tmp/out/frontend.tum")"
grep -q '"odometry_drift": "0,0.1"' "$tmp/long/stats.json" && grep -q '"odometry_drift": null' "$tmp/out/stats.json" \
  && ok "stats: odometry_drift" || bad "stats.json: odometry_drift"
[ "$(head -n 1 "$tmp/long/frontend.tum")" = "$(head -n 1 "$tmp/out/frontend.tum")" ] && ok "drift: the first pose is the frontend's" \
  || bad "drift: the first pose moved"
check "drift heading" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/turn" --config "$tmp/tiny.yaml" --odometry-drift 2,0
span=$(awk 'NR == 1 { t0 = $1 } END { printf "%.6f", $1 - t0 }' "$tmp/out/frontend.tum")
awk -v a="$(last_yaw_deg "$tmp/turn/frontend.tum")" -v b="$(last_yaw_deg "$tmp/out/frontend.tum")" -v s="$span" \
  'BEGIN { d = a - b; if (d > 180) d -= 360; if (d < -180) d += 360; exit !(s > 1 && d > 2 * s - 0.01 && d < 2 * s + 0.01) }' \
  && ok "drift: turned by 2 deg/s over ${span} s" || bad "drift: last yaw $(last_yaw_deg "$tmp/turn/frontend.tum") against $(last_yaw_deg "$tmp/out/frontend.tum") over $span s"
check "drift none" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/still" --config "$tmp/tiny.yaml" --odometry-drift 0,0
cmp -s "$tmp/still/frontend.tum" "$tmp/out/frontend.tum" && ok "drift: 0,0 is the frontend to the last digit" || bad "drift: 0,0 moved poses"
# --odometry-truth: the frontend's poses are the ground truth at the frames' times (frontend.tum
# on ground_truth.tum to the printed 0.1 mm), said in stats.json; a recording without the truth (a
# capture, or here one cut before its first chunk) is refused naming the topic.
check "truth" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/truth" --config "$tmp/tiny.yaml" --odometry-truth
out=$("$eval" --gt "$tmp/truth/ground_truth.tum" --est "$tmp/truth/frontend.tum" --align none 2>&1)
ape=$(awk '/^APE translation \(m\)/ { print $5 }' <<<"$out")
awk -v a="$ape" 'BEGIN { exit !(a != "" && a < 1e-4) }' && ok "truth: frontend.tum is the truth ($ape m)" || { bad "truth: APE '$ape' m"; echo "$out"; }
[ "$(grep -c . "$tmp/truth/frontend.tum")" = 63 ] && ok "truth: one pose per frame" || bad "truth: frontend.tum has $(grep -c . "$tmp/truth/frontend.tum") lines"
grep -q '"odometry_truth": true' "$tmp/truth/stats.json" && grep -q '"odometry_truth": false' "$tmp/out/stats.json" \
  && grep -q '"frames_without_truth": 0' "$tmp/truth/stats.json" && ok "stats: odometry_truth" || bad "stats.json: odometry_truth"
head -c 2048 "$tmp/rec.mcap" > "$tmp/head.mcap"
check "truth missing" 1 "--odometry-truth needs the recording's /ground_truth, which has 0 poses" "$replay" \
  --input "$tmp/head.mcap" --out "$tmp/x" --odometry-truth
check "truth with drift" 2 "--odometry-truth replaces" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --odometry-truth \
  --odometry-drift 0,0.1
check "drift malformed" 2 "--odometry-drift: expected DEG_PER_S,SCALE" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --odometry-drift 0.1
check "drift scale too large" 2 "--odometry-drift" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --odometry-drift 0,2

# bad usage and bad options
# the BA backend wired in: few keyframes (a fast test; the backend's accuracy is splat's tests')
cp "$tmp/tiny.yaml" "$tmp/tiny_ba.yaml"
printf 'backend:\n  keyframe_distance_m: 1.5\n  keyframe_angle_deg: 90.0\n  keyframe_time_s: 10.0\n  first_keyframe_mapping_iterations: 10\n  max_image_range_m: 6.0\n' >> "$tmp/tiny_ba.yaml"
check "backend ba" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/ba" --config "$tmp/tiny_ba.yaml" --backend ba
[ "$(grep -c . "$tmp/ba/estimate.tum")" = 63 ] && ok "ba: one pose per frame" || bad "ba: estimate.tum has $(grep -c . "$tmp/ba/estimate.tum") lines"
cmp -s "$tmp/ba/frontend.tum" "$tmp/ba/estimate.tum" && bad "ba: the backend changed no pose" || ok "ba: the backend corrects poses"
[ "$(grep -c . "$tmp/ba/estimate_final.tum")" = 63 ] && ok "ba: end-of-run trajectory, one pose per frame" \
  || bad "ba: estimate_final.tum has $(grep -c . "$tmp/ba/estimate_final.tum" 2>/dev/null) lines"
# The newest keyframe's frames and those after it are published as the map has them at the end.
[ "$(tail -n 1 "$tmp/ba/estimate_final.tum")" = "$(tail -n 1 "$tmp/ba/estimate.tum")" ] \
  && ok "ba: the last frame's end-of-run pose is the published one" || bad "ba: the last frames differ"
[ -s "$tmp/ba/map.png" ] && ok "ba: map.png" || bad "ba: no map.png"
out=$("$eval" --gt "$tmp/ba/ground_truth.tum" --est "$tmp/ba/estimate.tum" 2>&1)
ape=$(awk '/^APE translation \(m\)/ { print $5 }' <<<"$out")
awk -v a="$ape" 'BEGIN { exit !(a != "" && a < 0.1) }' && ok "ba: APE $ape m < 0.1 m" || { bad "ba: APE '$ape' m"; echo "$out"; }
# The paper's `no frontend` ablation wired in: the backend's own constant-velocity poses (its
# tracking is splat_backend_test's); one pose per frame, not the frontend's, and said in stats.json.
check "backend poses constant-velocity" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/alone" \
  --config "$tmp/tiny_ba.yaml" --backend ba --backend-poses constant-velocity --pictures 0
[ "$(grep -c . "$tmp/alone/estimate.tum")" = 63 ] && ok "alone: one pose per frame" || bad "alone: estimate.tum has $(grep -c . "$tmp/alone/estimate.tum") lines"
cmp -s "$tmp/alone/estimate.tum" "$tmp/ba/estimate.tum" && bad "alone: the same poses as with the frontend" || ok "alone: not the frontend's poses"
grep -q '"backend_poses": "constant-velocity"' "$tmp/alone/stats.json" && ok "stats: backend_poses" || bad "stats.json lacks backend_poses"
grep -q '"backend_poses": "frontend"' "$tmp/ba/stats.json" && ok "stats: backend_poses frontend" || bad "stats.json (ba) lacks backend_poses"
# The backend given the truth (its own floor): it moves the poses, and not far from where they were.
check "ba from the truth" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/batruth" --config "$tmp/tiny_ba.yaml" \
  --backend ba --odometry-truth --pictures 0
cmp -s "$tmp/batruth/frontend.tum" "$tmp/batruth/estimate.tum" && bad "ba from the truth: no pose moved" || ok "ba from the truth: poses refined"
for f in estimate estimate_final; do
  out=$("$eval" --gt "$tmp/batruth/ground_truth.tum" --est "$tmp/batruth/$f.tum" 2>&1)
  ape=$(awk '/^APE translation \(m\)/ { print $5 }' <<<"$out")
  awk -v a="$ape" 'BEGIN { exit !(a != "" && a < 0.05) }' && ok "ba from the truth: $f APE $ape m < 0.05 m" || { bad "ba from the truth: $f APE '$ape' m"; echo "$out"; }
done
check "backend poses unknown" 2 "--backend-poses" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --backend ba --backend-poses imu
check "backend poses without ba" 2 "needs --backend ba" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --backend-poses constant-velocity
check "backend poses pipelined" 2 "sequential" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --backend ba --pipelined \
  --backend-poses constant-velocity
# --repeatable: the stages' time budgets (here a microsecond, so that every stage would stop on
# them) are lifted, and two replays give the same trajectories to the last digit.
cp "$tmp/tiny_ba.yaml" "$tmp/tiny_budget.yaml"
printf '  pose: {time_budget_s: 0.000001}\n  mapping: {time_budget_s: 0.000001}\n  ba: {time_budget_s: 0.000001}\n' >> "$tmp/tiny_budget.yaml"
check "budgeted" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/budget" --config "$tmp/tiny_budget.yaml" \
  --backend ba --pictures 0
grep -q '"pose_budget_stops": [1-9]' "$tmp/budget/stats.json" && ok "budgeted: the stages stop on their budgets" \
  || bad "budgeted: no budget stop in stats.json"
for run in rep1 rep2; do
  check "repeatable $run" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/$run" --config "$tmp/tiny_budget.yaml" \
    --backend ba --pictures 0 --repeatable
done
grep -q '"repeatable": true' "$tmp/rep1/stats.json" && ok "stats: repeatable" || bad "stats.json lacks repeatable: true"
grep -q '"pose_budget_stops": 0' "$tmp/rep1/stats.json" && grep -q '"ba_budget_stops": 0' "$tmp/rep1/stats.json" \
  && ok "repeatable: no budget stops" || bad "repeatable: budget stops in stats.json"
cmp -s "$tmp/rep1/estimate.tum" "$tmp/rep2/estimate.tum" && cmp -s "$tmp/rep1/estimate_final.tum" "$tmp/rep2/estimate_final.tum" \
  && ok "repeatable: two replays, the same trajectories" || bad "repeatable: two replays differ"
cmp -s "$tmp/rep1/estimate.tum" "$tmp/rep1/frontend.tum" && bad "repeatable: the backend changed no pose" || ok "repeatable: poses corrected"
check "repeatable without ba" 2 "--repeatable needs --backend ba" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --repeatable
check "repeatable pipelined" 2 "--repeatable needs --backend ba, sequential" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" \
  --backend ba --pipelined --repeatable
# frontend.whole_run_smoother: the whole run solved as one batch at its end, its poses in
# frontend_smoothed.tum (one per frame, at the frames' stamps) and under the end-of-run trajectory.
# Repeatable, against rep1 (the same options without it).
sed 's/^  whole_run_smoother: false/  whole_run_smoother: true/' "$tmp/tiny_budget.yaml" > "$tmp/tiny_smooth.yaml"
check "whole-run smoother" 0 "63 frames" "$replay" --input "$tmp/rec.mcap" --out "$tmp/smooth" --config "$tmp/tiny_smooth.yaml" \
  --backend ba --pictures 0 --repeatable
cmp -s <(cut -d' ' -f1 "$tmp/smooth/frontend.tum") <(cut -d' ' -f1 "$tmp/smooth/frontend_smoothed.tum") \
  && ok "smoother: one pose per frame at its stamp" || bad "smoother: frontend_smoothed.tum's stamps are not frontend.tum's"
cmp -s "$tmp/smooth/frontend.tum" "$tmp/rep1/frontend.tum" && cmp -s "$tmp/smooth/estimate.tum" "$tmp/rep1/estimate.tum" \
  && ok "smoother: what is published is unchanged" || bad "smoother: the published poses changed"
cmp -s "$tmp/smooth/estimate_final.tum" "$tmp/rep1/estimate_final.tum" && bad "smoother: the end of run is unchanged" \
  || ok "smoother: the end of run follows it"
[ -e "$tmp/rep1/frontend_smoothed.tum" ] && bad "smoother: frontend_smoothed.tum without the option" || ok "smoother: off by default"
grep -q '"whole_run_smoother_s": [0-9]' "$tmp/smooth/stats.json" && ok "stats: whole_run_smoother_s" || bad "stats.json lacks whole_run_smoother_s"
out=$("$eval" --gt "$tmp/smooth/ground_truth.tum" --est "$tmp/smooth/frontend_smoothed.tum" 2>&1)
ape=$(awk '/^APE translation \(m\)/ { print $5 }' <<<"$out")
awk -v a="$ape" 'BEGIN { exit !(a != "" && a < 0.05) }' && ok "smoother: APE $ape m < 0.05 m" || { bad "smoother: APE '$ape' m"; echo "$out"; }
check "smoother with drift" 2 "whole_run_smoother" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --config "$tmp/tiny_smooth.yaml" \
  --backend ba --odometry-drift 0,0.1
check "smoother with truth" 2 "whole_run_smoother" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --config "$tmp/tiny_smooth.yaml" \
  --backend ba --odometry-truth
# rsrio-eval --ablation on a recording put where it looks for sequence 1: only the rows asked for
# are replayed and printed (each into its own directory), an unknown row is a usage error.
mkdir -p "$tmp/data" && cp "$tmp/rec.mcap" "$tmp/data/seq1_meeting_room.mcap"
check "ablation rows" 0 "backend off (frontend only)" "$eval" --ablation --sequences 1 --variants nobackend \
  --data "$tmp/data" --config "$tmp/tiny.yaml"
[ -s "$tmp/data/seq1_meeting_room_ablation_nobackend/estimate.tum" ] && ok "ablation: the row's replay" || bad "ablation: no replay of the row"
ls -d "$tmp/data"/seq1_meeting_room_* | grep -qv '_ablation_nobackend$' && bad "ablation: rows not asked for were replayed" \
  || ok "ablation: no other row replayed"
check "ablation repeatable" 0 "no BA" "$eval" --ablation --sequences 1 --variants noba --repeatable \
  --data "$tmp/data" --config "$tmp/tiny.yaml"
grep -q '"repeatable": true' "$tmp/data/seq1_meeting_room_ablation_noba_repeatable/stats.json" \
  && ok "ablation: the repeatable row in its own directory" || bad "ablation: no repeatable replay of the row"
check "ablation unknown row" 2 "unknown variant 'r7' (one of: full, noba, r1" "$eval" --ablation --variants noba,r7 --data "$tmp/data"
check "repeatable without a table" 2 "--repeatable needs --table" "$eval" --gt "$tmp/out/ground_truth.tum" \
  --est "$tmp/out/estimate.tum" --repeatable
check "eval: missing file" 1 "nothing.tum: cannot open" "$eval" --gt "$tmp/out/ground_truth.tum" --est "$tmp/nothing.tum"
check "eval: bad --delta" 2 "--delta: expected metres > 0, got 'x'" "$eval" --gt "$tmp/out/ground_truth.tum" \
  --est "$tmp/out/estimate.tum" --delta x
check "eval: bad --align" 2 "alignment 'sim3'" "$eval" --gt "$tmp/out/ground_truth.tum" --est "$tmp/out/estimate.tum" \
  --align sim3
check "variants without ablation" 2 "--variants needs --ablation" "$eval" --table --variants noba --data "$tmp/data"
check "backend unknown" 2 "--backend" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --backend foo
check "no input" 2 "--input and --out are required" "$replay" --out "$tmp/x"
printf 'frontend:\n  window_state: 5\n' > "$tmp/typo.yaml"
check "unknown key" 2 "frontend.window_state" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --config "$tmp/typo.yaml"
printf 'ego_velocity:\n  dimensions: 4\n' > "$tmp/range.yaml"
check "out of range" 2 "ego_velocity.dimensions" "$replay" --input "$tmp/rec.mcap" --out "$tmp/x" --config "$tmp/range.yaml"
check "missing recording" 1 "$tmp/none.mcap" "$replay" --input "$tmp/none.mcap" --out "$tmp/x"

echo "$fails failed"
[ "$fails" = 0 ]

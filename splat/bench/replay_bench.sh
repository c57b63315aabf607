#!/usr/bin/env bash
# The full pipeline's speed on a scenario (default the longest, sequence 5): rsrio-replay
# --backend ba over the same recording twice in one run, sequential (one thread: DSP, frontend and
# backend in turn, as rsrio-eval --table replays) and --pipelined (the backend on its own thread,
# as in rsriod; the second core). Prints per mode: wall time, the real-time factor (recording
# seconds / wall seconds), the backend's time per keyframe (p50 / p99), keyframes, BA budget
# stops, peak memory, and the APE (SE(3)) of the published and of the end-of-run trajectory
# against the simulator's ground truth; then the ratio of the two real-time factors.
# usage: replay_bench.sh BIN_DIR DATA_DIR [SCENARIO [CONFIG]]   (SCENARIO: a name in scenarios/,
#        default seq5_medium_large_loop; its recording is made in DATA_DIR when missing: 10 GB,
#        ~9 min; CONFIG: the options file, default config/rsrio.yaml)
# Run alone: the backend's stages have time budgets, so a loaded machine changes the results.
set -euo pipefail
bin=$1 data=$2 scenario=${3:-seq5_medium_large_loop} config=${4:-config/rsrio.yaml}
mkdir -p "$data"
rec=$data/$scenario.mcap
if [ ! -s "$rec" ]; then
  echo "simulating $scenario into $rec ..." >&2
  "$bin/rsrio-sim" --scenario "scenarios/$scenario.yaml" --out "$rec.part" >"$data/$scenario.sim.log" 2>&1 \
    || { tail "$data/$scenario.sim.log"; exit 1; }
  mv "$rec.part" "$rec"
fi
for mode in sequential pipelined; do
  out=$data/${scenario}_bench_$mode
  flag=""; [ $mode = pipelined ] && flag=--pipelined
  echo "replaying $scenario ($mode) ..." >&2
  "$bin/rsrio-replay" --input "$rec" --out "$out" --config "$config" --backend ba $flag --quiet \
    >"$out.log" 2>&1 || { tail "$out.log"; exit 1; }
  for f in estimate estimate_final; do
    "$bin/rsrio-eval" --gt "$out/ground_truth.tum" --est "$out/$f.tum" >"$out/ape_$f.txt" 2>&1
  done
done
python3 - "$data" "$scenario" "$config" <<'PY'
import json, re, sys
data, scenario, config = sys.argv[1], sys.argv[2], sys.argv[3]
def ape(path):
    t = r = float("nan")
    for line in open(path):
        m = re.match(r"APE (translation \(m\)|rotation \(deg\))\s+rmse\s+([0-9.]+)", line)
        if m:
            if m.group(1).startswith("translation"): t = float(m.group(2))
            else: r = float(m.group(2))
    return t, r
rows, rtf = [], {}
for mode in ("sequential", "pipelined"):
    out = f"{data}/{scenario}_bench_{mode}"
    s = json.load(open(f"{out}/stats.json"))
    b, kf = s["backend_stats"], s["timings_ms"]["backend_keyframe"]
    rtf[mode] = s["recording_seconds"] / s["wall_seconds"]
    pub, end = ape(f"{out}/ape_estimate.txt"), ape(f"{out}/ape_estimate_final.txt")
    rows.append(f"| {mode} | {s['wall_seconds']:.0f} | {s['recording_seconds']:.0f} | {rtf[mode]:.2f} | "
                f"{kf['p50']:.0f} / {kf['p99']:.0f} | {b['keyframes']} | {b['ba_budget_stops']} | "
                f"{s['peak_memory_mb']:.0f} | {pub[0]:.3f} / {pub[1]:.2f} | {end[0]:.3f} / {end[1]:.2f} |")
print(f"rsrio-replay --backend ba --config {config} on {scenario}")
print("| mode | wall (s) | recording (s) | real-time factor | backend ms/keyframe p50 / p99 | keyframes "
      "| BA budget stops | peak MB | APE published t (m) / r (deg) | APE end of run |")
print("|---|---|---|---|---|---|---|---|---|---|")
print("\n".join(rows))
print(f"pipelined / sequential real-time factor: {rtf['pipelined'] / rtf['sequential']:.2f}")
PY

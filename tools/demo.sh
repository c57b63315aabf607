#!/usr/bin/env bash
# ./rsrio demo: the daemon as it runs on a robot, with a simulated board instead of the radar.
#
#   rsrio-dca1000-emu  speaks the DCA1000 protocol on 127.0.0.2 and streams the raw ADC of a
#                      simulated walk (scenarios/demo_meeting_room.yaml) at 10 Hz, and publishes
#                      the walk's IMU on DDS /imu, stamped on the same clock;
#   rsriod             captures through its DCA1000 driver, takes the IMU from DDS, publishes
#                      odometry on DDS /rsrio/odom;
#   rsrio-echo         another process, receives the odometry over DDS and keeps it as a trajectory;
#   rsrio-eval         its accuracy against the walk's ground truth, and a plot.
# usage (through ./rsrio demo): demo.sh BIN_DIR OUT_DIR
set -euo pipefail
bin=$1 out=$2
mkdir -p "$out"
scenario=scenarios/demo_meeting_room.yaml
domain=${RSRIO_DEMO_DOMAIN:-$((200 + $$ % 30))}
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT

# The daemon's configuration: the demo's board and radar, the estimator's shipped defaults (whose
# radar-IMU extrinsic is the scenario's rig).
{
  printf 'daemon:\n  radar_source: "dca1000://127.0.0.2:127.0.0.1"\n  imu_source: dds\n  imu_topic: /imu\n'
  printf '  domain_id: %d\n  radar_timeout_s: 2.0\n' "$domain"
  printf 'radar:\n  preset: xwr1843\n  frame_period_ms: 100.0\n'
  grep -v '^%YAML' config/rsrio.yaml | grep -v '^---'
} >"$out/rsriod.yaml"

echo "rsrio demo: a simulated DCA1000 + xWR1843 streams a 45 s walk round a meeting room;"
echo "rsriod turns it into odometry on DDS; rsrio-echo (another process) receives it. Logs in $out/."
"$bin/rsrio-echo" --domain "$domain" --quiet --status --tum "$out/estimate.tum" >"$out/echo.log" 2>&1 &
pids+=($!)
"$bin/rsriod" --config "$out/rsriod.yaml" --progress 2>"$out/rsriod.log" >"$out/rsriod.out" &
daemon=$!
pids+=($daemon)
sleep 2   # the daemon's driver connects when the board answers; DDS discovery meanwhile
"$bin/rsrio-dca1000-emu" --scenario "$scenario" --address 127.0.0.2 --host-data 127.0.0.1:4098 \
  --once --imu-topic /imu --domain "$domain" --ground-truth "$out/ground_truth.tum" >"$out/emulator.log" 2>&1 &
emulator=$!
pids+=($emulator)

# Live progress: what the subscriber has received, from its status and odometry.
while kill -0 "$emulator" 2>/dev/null; do
  poses=$( [ -f "$out/estimate.tum" ] && wc -l <"$out/estimate.tum" || echo 0)
  status=$(grep "^status" "$out/echo.log" | tail -n 1 | sed 's/^status level [0-9] //' | cut -c1-90)
  printf '\r  %4d poses received   %s   ' "$poses" "$status"
  sleep 1
done
echo
wait "$emulator" || { echo "the board emulator failed:"; tail -n 20 "$out/emulator.log"; exit 1; }
sleep 1
kill -TERM "$daemon"
wait "$daemon" || { echo "rsriod failed:"; tail -n 20 "$out/rsriod.log"; exit 1; }
kill -INT "${pids[0]}"; wait "${pids[0]}" || true
pids=()

echo "rsriod: $(grep -o 'stopped after [0-9]* poses' "$out/rsriod.log")"
echo "accuracy of the received odometry against the walk's ground truth (after SE(3) alignment):"
"$bin/rsrio-eval" --gt "$out/ground_truth.tum" --est "$out/estimate.tum" --align se3 --plot "$out/trajectory.png"
echo "trajectory plot: $out/trajectory.png"

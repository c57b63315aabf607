#!/usr/bin/env bash
# rsrio-dsp as a person uses it: the real OpenRadar frame -> every output file, with the scene's
# two objects in points.csv; bad command lines and bad options -> one clear message, exit 2.
# With a second argument (rsrio-sim), also --input on a simulated recording.
set -u
bin=$1
sim=${2:-}
tmp=$(mktemp -d)
trap 'rm -rf -- "$tmp"' EXIT
fails=0
ok() { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
check() { # name expected_rc expected_text args...
  local name=$1 want_rc=$2 want=$3 out rc
  shift 3
  out=$("$bin" "$@" 2>&1); rc=$?
  if [ "$rc" != "$want_rc" ] || ! grep -qF -- "$want" <<<"$out"; then
    bad "$name: rc=$rc (want $want_rc), output lacks '$want':"; echo "$out" | sed 's/^/    /'
  else
    ok "$name"
  fi
}
npy=../shared/data/openradar/doppler_example_1.npy
cfg=config/radar/openradar_frame.yaml

# the real frame
check "openradar run" 0 "points ->" --npy "$npy" --config "$cfg" --out "$tmp/or" --rad
for f in ra.npy rd.npy rad.npy axes.json points.csv ra.png rd.png; do
  [ -s "$tmp/or/$f" ] && ok "wrote $f" || bad "missing $f"
done
head -n 1 "$tmp/or/points.csv" | grep -qx 'range_m,azimuth_deg,elevation_deg,doppler_mps,snr_db,azimuth_ambiguous' && ok "points.csv header" || bad "points.csv header"
# static reflector near 5.21 m at 0 m/s, moving target near 2.93 m at +0.59 m/s
awk -F, 'NR > 1 && $1 > 5.1 && $1 < 5.35 && $4 > -0.05 && $4 < 0.05 && $5 > 30 { f = 1 } END { exit !f }' "$tmp/or/points.csv" \
  && ok "static reflector in points.csv" || bad "static reflector not in points.csv"
awk -F, 'NR > 1 && $1 > 2.8 && $1 < 3.05 && $4 > 0.5 && $4 < 0.7 && $5 > 30 { f = 1 } END { exit !f }' "$tmp/or/points.csv" \
  && ok "moving target in points.csv" || bad "moving target not in points.csv"
# .npy headers: float32, the documented shapes (128 range bins, 128 Doppler, 64 azimuth)
grep -aq "'descr': '<f4', 'fortran_order': False, 'shape': (128, 64)" "$tmp/or/ra.npy" && ok "ra.npy shape" || bad "ra.npy shape"
grep -aq "'shape': (128, 128)" "$tmp/or/rd.npy" && ok "rd.npy shape" || bad "rd.npy shape"
grep -aq "'shape': (128, 128, 64)" "$tmp/or/rad.npy" && ok "rad.npy shape" || bad "rad.npy shape"
grep -q '"doppler_mps": \[' "$tmp/or/axes.json" && grep -q '"azimuth_deg": \[' "$tmp/or/axes.json" && ok "axes.json grids" || bad "axes.json grids"
head -c 8 "$tmp/or/ra.png" | od -An -tx1 | grep -q '89 50 4e 47' && ok "ra.png is a PNG" || bad "ra.png is not a PNG"
# options printed at start-up
check "options printed" 0 "tdm_compensation: true" --npy "$npy" --config "$cfg" --out "$tmp/or2"

# a preset with a matching frame shape is refused when the shape differs
check "shape mismatch" 1 "does not fit the radar configuration" --npy "$npy" --radar xwr1843 --out "$tmp/x"
# command-line errors
check "no input" 2 "exactly one of --input" --radar xwr1843 --out "$tmp/x"
check "two inputs" 2 "exactly one of --input" --npy "$npy" --input x.mcap --radar xwr1843 --out "$tmp/x"
check "no out" 2 "missing --out" --npy "$npy" --radar xwr1843
check "npy without radar" 2 "--npy needs a radar configuration" --npy "$npy" --out "$tmp/x"
check "bad preset" 2 "--radar: expected one of" --npy "$npy" --radar awr9999 --out "$tmp/x"
check "frame without input" 2 "--frame goes with --input" --npy "$npy" --frame 2 --radar xwr1843 --out "$tmp/x"
check "missing npy" 1 "cannot open" --npy "$tmp/absent.npy" --radar xwr1843 --out "$tmp/x"
# bad options: the file and the key named, exit 2
printf 'radar:\n  preset: xwr1843\ndsp:\n  cfar:\n    pfa: 2\n' > "$tmp/pfa.yaml"
check "bad pfa" 2 "key 'dsp.cfar.pfa'" --npy "$npy" --config "$tmp/pfa.yaml" --out "$tmp/x"
printf 'dsp:\n  windw: hann\n' > "$tmp/typo.yaml"
check "unknown key" 2 "key 'dsp.windw'" --npy "$npy" --radar xwr1843 --config "$tmp/typo.yaml" --out "$tmp/x"
check "help" 0 "usage: rsrio-dsp" --help

if [ -n "$sim" ]; then
  if "$sim" --scenario scenarios/test_tiny.yaml --out "$tmp/tiny.mcap" --seconds 0.5 >/dev/null 2>&1; then
    check "recording frame 2" 0 "points ->" --input "$tmp/tiny.mcap" --frame 2 --out "$tmp/rec"
    [ "$(wc -l < "$tmp/rec/points.csv")" -gt 3 ] && ok "recording gives points" || bad "recording gives no points"
    check "recording frame out of range" 1 "frame 99 asked for" --input "$tmp/tiny.mcap" --frame 99 --out "$tmp/rec2"
    check "recording with preset override" 1 "the radar configuration needs" --input "$tmp/tiny.mcap" --radar mmwcas --out "$tmp/rec3"
  else
    bad "rsrio-sim could not make a recording"
  fi
  check "missing recording" 1 "absent.mcap" --input "$tmp/absent.mcap" --out "$tmp/rec4"
fi

echo "$fails failure(s)"
[ "$fails" = 0 ]

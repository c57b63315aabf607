#!/usr/bin/env bash
# rsrio-config as a person uses it: every kind of bad file -> one message naming file and key,
# exit 2; the shipped presets -> exit 0 and the derived figures (checked against hand values).
set -u
bin=$1
tmp=$(mktemp -d)
trap 'rm -rf -- "$tmp"' EXIT
fails=0
check() { # name expected_rc expected_text file
  local name=$1 want_rc=$2 want=$3 f=$4 out rc
  out=$("$bin" "$f" 2>&1); rc=$?
  if [ "$rc" != "$want_rc" ] || ! grep -qF -- "$want" <<<"$out"; then
    echo "FAIL $name: rc=$rc (want $want_rc), output lacks '$want':"; echo "$out" | sed 's/^/    /'
    fails=$((fails + 1))
  else
    echo "ok   $name: $(head -n 1 <<<"$out")"
  fi
}
printf 'radar:\n  preset: xwr1843\n  chirp:\n    slope: 30\n' > "$tmp/unknown.yaml"
printf 'radar:\n  preset: xwr1843\n  loops: lots\n' > "$tmp/type.yaml"
printf 'radar:\n  preset: xwr1843\n  frame_period_ms: -3\n' > "$tmp/range.yaml"
printf 'radar:\n  loops: 16\n' > "$tmp/missing.yaml"
printf 'radar: [1, 2\n  : : :\n' > "$tmp/notyaml.yaml"
printf 'radar:\n  preset: mmwcas\n  chirp:\n    ramp_end_time_us: 20\n' > "$tmp/physics.yaml"
check "unknown key"   2 "key 'radar.chirp.slope'" "$tmp/unknown.yaml"
check "wrong type"    2 "key 'radar.loops': expected an integer" "$tmp/type.yaml"
check "out of range"  2 "key 'radar.frame_period_ms': expected a number in" "$tmp/range.yaml"
check "missing key"   2 "key 'radar.preset'" "$tmp/missing.yaml"
check "not YAML"      2 "$tmp/notyaml.yaml: expected a YAML file" "$tmp/notyaml.yaml"
check "missing file"  2 "$tmp/absent.yaml: expected an existing file" "$tmp/absent.yaml"
check "ramp too short" 2 "key 'radar.chirp.ramp_end_time_us'" "$tmp/physics.yaml"
# A bad command line: one line naming what is wrong, then the hint (common/src/cli.cpp, every program).
check "unknown option" 2 "rsrio-config: error: unknown option --bogus" --bogus
check "usage hint"     2 "(see rsrio-config --help)" --bogus
check "no file"        2 "rsrio-config: error: missing FILE" ""
# Hand-computed: xwr1843 dR = c / (2 * 29.982e12 * 256 / 5e6) = 0.0976473 m, Rmax = 24.9977 m,
# vmax = lambda / (4 * 3 * 70 us) = 4.57867 m/s, vres = 0.143084 m/s.
check "xwr1843 range res" 0 "range_resolution_m: 0.0976473" config/radar/xwr1843.yaml
check "xwr1843 max range" 0 "max_range_m: 24.9977" config/radar/xwr1843.yaml
check "xwr1843 max vel"   0 "max_velocity_mps: 4.57867" config/radar/xwr1843.yaml
check "xwr1843 vel res"   0 "velocity_resolution_mps: 0.143084" config/radar/xwr1843.yaml
# mmwcas: dR = c / 2.048e9 = 0.146383 m, Rmax = 18.737 m, vmax = 2.23134 m/s, 86 azimuth elements.
check "mmwcas range res" 0 "range_resolution_m: 0.146383" config/radar/mmwcas.yaml
check "mmwcas max range" 0 "max_range_m: 18.737" config/radar/mmwcas.yaml
check "mmwcas max vel"   0 "max_velocity_mps: 2.23134" config/radar/mmwcas.yaml
check "mmwcas array"     0 "86 unique azimuth elements" config/radar/mmwcas.yaml
check "openradar frame"  0 "range_resolution_m: 0.0487943" config/radar/openradar_frame.yaml
out=$("$bin" --version); [ $? = 0 ] && grep -q "rsrio" <<<"$out" || { echo "FAIL --version"; fails=$((fails+1)); }
out=$("$bin" --help); [ $? = 0 ] && grep -q -- "--config" <<<"$out" || { echo "FAIL --help"; fails=$((fails+1)); }
"$bin" --bogus >/dev/null 2>&1; [ $? = 2 ] || { echo "FAIL bad flag exit code"; fails=$((fails+1)); }
echo "$fails failed"
[ "$fails" = 0 ]

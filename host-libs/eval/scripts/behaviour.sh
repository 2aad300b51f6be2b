#!/usr/bin/env bash
# Behaviour check of the model loop: a fixed set of logs from the twin (`pamctl simulate`)
# and from pam-synth, each diagnosed with `pamctl model diagnose --json`.
#
#   behaviour.sh record DIR    write the logs and their diagnoses to DIR
#   behaviour.sh compare DIR   write them again to a temporary folder and compare with DIR:
#                              exit 0 if every diagnosis is byte-identical, else list the
#                              differences (numbers that differ by a relative 1e-9 or less
#                              are listed as "within tolerance") and exit 1
#
# PAMCTL and PAM_SYNTH name the binaries (default: $CARGO_TARGET_DIR/debug/{pamctl,pam-synth}).
set -euo pipefail
mode=${1:?record|compare}
dir=${2:?folder}
tgt=${CARGO_TARGET_DIR:-target}
P=${PAMCTL:-$tgt/debug/pamctl}
S=${PAM_SYNTH:-$tgt/debug/pam-synth}

cases() {
  # name | generator | arguments
  local e
  local seed=1
  for e in none carrier_ball_friction velocity_squared nonlinear_stiffness muscle_hysteresis \
           asymmetric_ip_rates pressure_saturation pose_dependence cable_slip transport_delay loadcell_drift; do
    local with=""
    [ "$e" != none ] && with="--with $e"
    echo "twin_dyn_$e|twin|--experiment dynamic --point 1 --duration 30 --period 0.01 --seed $seed $with"
    seed=$((seed + 1))
  done
  echo "twin_dyn_high|twin|--experiment dynamic --point 1 --stiffness high --duration 30 --period 0.01 --seed 20"
  echo "twin_dyn_two|twin|--experiment dynamic --point 1 --duration 30 --period 0.01 --seed 21 --with carrier_ball_friction:coulomb_n=3 --with loadcell_drift"
  echo "twin_static|twin|--experiment static --point 1 --period 0.01 --seed 22"
  echo "twin_imp|twin|--experiment impedance --duration 20 --period 0.001 --seed 23"
  for e in none asymmetric_ip_rates pressure_saturation transport_delay muscle_hysteresis loadcell_drift; do
    local with=""
    [ "$e" != none ] && with="--with $e"
    echo "twin_step_$e|twin|--experiment force_step --pose $(( seed % 9 )) --period 0.05 --seed $seed $with"
    seed=$((seed + 1))
  done
  echo "twin_step_cl|twin|--experiment force_step --pose 4 --closed-loop --seed 30"
  echo "twin_step_ff|twin|--experiment force_step --pose 2 --period 0.05 --feed-forward --seed 31"
  local f s
  seed=100
  for fs in none/control friction/coulomb friction/viscous_plus_coulomb friction/stribeck friction/lugre \
            drag/quadratic hysteresis/bouc_wen hysteresis/elastic_loop hysteresis/maxwell_slip \
            backlash/joint_play stiffness_nonlinearity/cubic_neutral stiffness_nonlinearity/cubic_equilibrium \
            pose_dependence/cartesian_linear pose_dependence/joint_gain_plane drift/offset_linear \
            drift/offset_exponential delay/sensor_sync unexplained/mains_tone unexplained/slow_wander; do
    f=${fs%/*}; s=${fs#*/}
    local dt=0.01
    [ "$s" = mains_tone ] && dt=0.002
    echo "synth_dyn_${f}_$s|synth|--seed $seed --experiment dynamic --family $f --shape $s --duration-s 40 --period-s $dt"
    seed=$((seed + 1))
  done
  echo "synth_dyn_nuis|synth|--seed 150 --experiment dynamic --family friction --shape coulomb --nuisance random --motion random --period-s 0.01"
  echo "synth_dyn_lsb|synth|--seed 151 --experiment dynamic --family none --shape control --nuisance lsb=2 --motion reach_and_hold --period-s 0.01"
  for fs in none/control hysteresis/direction_offset hysteresis/force_play drift/offset_linear \
            drift/offset_exponential delay/dead_time delay/tube_lag rate_limits/output_slew \
            rate_limits/input_slew saturation/hard_clip saturation/tanh_knee saturation/pressure_cap unexplained/mains_tone; do
    f=${fs%/*}; s=${fs#*/}
    local period=""
    [ "$s" = mains_tone ] && period="--period-s 0.002"
    echo "synth_step_${f}_$s|synth|--seed $seed --experiment step --family $f --shape $s $period"
    seed=$((seed + 1))
  done
  echo "synth_step_levels|synth|--seed 170 --experiment step --family delay --shape dead_time --step-levels random --step-order x_then_y"
}

run_all() {
  local out=$1
  mkdir -p "$out"
  local name gen args
  while IFS='|' read -r name gen args; do
    # shellcheck disable=SC2086
    if [ "$gen" = twin ]; then
      "$P" simulate $args --out "$out/$name.csv" > /dev/null 2> "$out/$name.gen.err" || true
    else
      "$S" $args --out "$out/$name.csv" > /dev/null 2> "$out/$name.gen.err" || true
    fi
    if [ ! -s "$out/$name.csv" ]; then
      echo "$name: the generator wrote no log: $(cat "$out/$name.gen.err")" >&2
      exit 1
    fi
    "$P" model diagnose --json "$out/$name.csv" > "$out/$name.json" 2> "$out/$name.err" || echo "exit $?" >> "$out/$name.err"
  done < <(cases)
}

case $mode in
  record) run_all "$dir"; echo "$(ls "$dir"/*.json | wc -l) diagnoses in $dir" ;;
  compare)
    new=$(mktemp -d)
    run_all "$new"
    python3 - "$dir" "$new" <<'PY'
import json, math, os, sys
old, new = sys.argv[1], sys.argv[2]
names = sorted(f for f in os.listdir(old) if f.endswith('.json'))
exact = tol = 0
diffs = []
def walk(a, b, path):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                diffs.append((path + '/' + k, 'missing on one side', None)); continue
            walk(a[k], b[k], path + '/' + k)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)): walk(x, y, f'{path}[{i}]')
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if a != b:
            rel = abs(a - b) / max(abs(a), abs(b), 1e-300)
            diffs.append((path, f'{a!r} -> {b!r}', rel))
    elif a != b:
        diffs.append((path, f'{a!r} -> {b!r}', None))
bad = 0
for n in names:
    a = open(os.path.join(old, n)).read(); b = open(os.path.join(new, n)).read()
    if a == b: exact += 1; continue
    diffs.clear()
    walk(json.loads(a), json.loads(b), n)
    big = [d for d in diffs if d[2] is None or d[2] > 1e-9]
    if big: bad += 1
    else: tol += 1
    for p, what, rel in diffs:
        print(f"{'within tolerance' if rel is not None and rel <= 1e-9 else 'DIFFERENT'}: {p}: {what}" + (f" (rel {rel:.1e})" if rel is not None else ''))
print(f"{len(names)} diagnoses: {exact} identical, {tol} within 1e-9 relative, {bad} different")
sys.exit(1 if bad or tol else 0)
PY
    ;;
esac

#!/bin/bash
# `pamctl model diagnose` against a simple numpy least-squares script on the same file, in
# one run: a 90 s two-axis dynamic log at 1 kHz from the second generator (pam-synth), each
# timed best of three from the command line (file read included on both sides). The numpy
# script fits one mass-spring-damper by np.linalg.lstsq (the thesis's eq. 4.28 regression:
# no base variants, no effects, no cross-validation), so the ratio is what the whole
# diagnosis costs against one naive fit.
#   bash host-libs/eval/scripts/numpy_ratio.sh        (needs python3; installs numpy with pip if missing)
set -euo pipefail
cd "$(dirname "$0")/../../.."
python3 -c 'import numpy' 2>/dev/null || python3 -m pip install --quiet numpy
cargo build --quiet --release -p pamctl -p pam-synth
TARGET=$(cargo metadata --format-version 1 --no-deps | grep -o '"target_directory":"[^"]*"' | sed 's/^"target_directory":"//; s/"$//')
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
log=$work/dynamic.csv
# seed 7: a dynamic control; --period-s and --duration-s fix 90 s at 1 kHz
"$TARGET/release/pam-synth" --seed 7 --experiment dynamic --family none --period-s 0.001 --duration-s 90 --out "$log" >/dev/null
cat > "$work/naive.py" <<'PY'
import sys, numpy as np
with open(sys.argv[1]) as fh:
    lines = [l for l in fh if not l.startswith("#")]
names = lines[0].strip().split(",")
data = np.loadtxt(lines[1:], delimiter=",")
d = {k: data[:, i] for i, k in enumerate(names)}
t = d["t_s"]; a1 = d["alpha1_rad"]; a2 = d["alpha2_rad"]
l1, l2 = 0.700, 0.450
x = l1 * np.cos(a1) + l2 * np.cos(a1 + a2); y = l1 * np.sin(a1) + l2 * np.sin(a1 + a2)
cols = []
for p in (x, y):
    v = np.gradient(p, t); acc = np.gradient(v, t)
    cols.append((p - p[:100].mean(), v, acc))
(dx, vx, ax), (dy, vy, ay) = cols
n = len(t); z = np.zeros(n); one = np.ones(n)
X = np.vstack([
    np.column_stack([ax, ay, z, vx, vy, z, dx, dy, z, one, z]),
    np.column_stack([z, ax, ay, z, vx, vy, z, dx, dy, z, one]),
])
f = -np.concatenate([d["fx_n"], d["fy_n"]])
theta, *_ = np.linalg.lstsq(X, f, rcond=None)
print(" ".join(f"{v:.4g}" for v in theta))
PY
best() { # best wall time of three runs of a command, seconds
  local b=999
  for _ in 1 2 3; do
    local s e
    s=$(date +%s.%N); "$@" >/dev/null; e=$(date +%s.%N)
    b=$(python3 -c "print(min($b, $e - $s))")
  done
  echo "$b"
}
samples=$(grep -vc '^#' "$log")
t_pam=$(best "$TARGET/release/pamctl" model diagnose --experiment dynamic "$log" --json)
t_np=$(best python3 "$work/naive.py" "$log")
python3 - "$samples" "$t_pam" "$t_np" <<'PY'
import sys
n, a, b = int(sys.argv[1]) - 1, float(sys.argv[2]), float(sys.argv[3])
print(f"{n} samples: pamctl model diagnose {a:.2f} s, numpy lstsq script {b:.2f} s, ratio {a / b:.1f}x")
PY

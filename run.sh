#!/usr/bin/env bash
# The main job: start the device emulator (pam-device, the firmware's own device service,
# against the digital twin at 1 kHz in real time), make the robot respond over the link
# protocol, watch it, and stop the emulator. Extra arguments go to `pamctl sim`, e.g.
#   ./run.sh --with mains_hum --handle operator
# Runs from any directory; honours CARGO_TARGET_DIR (absolute, or relative to the directory
# it is run from) and cargo's build.target-dir.
set -euo pipefail
if [ -n "${CARGO_TARGET_DIR:-}" ] && [ "${CARGO_TARGET_DIR#/}" = "$CARGO_TARGET_DIR" ]; then
    CARGO_TARGET_DIR="$PWD/$CARGO_TARGET_DIR"   # relative to here, not to the repository
fi
cd "$(dirname "$0")"
cargo build --quiet --release -p pamctl
# where cargo put it: "target_directory":"..." in its metadata
target_dir=$(cargo metadata --format-version 1 --no-deps | grep -o '"target_directory":"[^"]*"' | sed 's/^"target_directory":"//; s/"$//')
pamctl=$target_dir/release/pamctl
[ -x "$pamctl" ] || { echo "run.sh: no pamctl at $pamctl after the build" >&2; exit 1; }
work=$(mktemp -d)
# a script runs one pamctl per step: allow 1 s between them (the firmware's default is 0.1 s)
"$pamctl" sim --listen 127.0.0.1:0 --command-timeout-s 1 "$@" >"$work/sim.out" 2>"$work/sim.err" &
sim=$!
stop_sim() {
    kill -INT "$sim" 2>/dev/null || true
    wait "$sim" 2>/dev/null || true
    cat "$work/sim.err" >&2
    rm -rf "$work"
}
trap stop_sim EXIT
for _ in $(seq 100); do
    grep -q '^listening on ' "$work/sim.out" && break
    kill -0 "$sim" 2>/dev/null || { cat "$work/sim.err" >&2; exit 1; }
    sleep 0.05
done
export PAMCTL_DEVICE
PAMCTL_DEVICE=$(sed -n 's/^listening on //p' "$work/sim.out")
cat "$work/sim.out"
echo "== status";                         "$pamctl" status
echo "== home, arm";                      "$pamctl" home; "$pamctl" arm
echo "== joint mode: go to (10°, 6.5°), Table 4.1 point 4"
"$pamctl" set joint --alpha-deg 10,6.5 --stiffness-nm-per-rad 95,40
# only the client that armed or set the mode keeps it alive; watch and record only listen
# unless --keep-alive makes them the commander (mode unchanged)
echo "== watch 5 s";                      "$pamctl" watch --seconds 5 --keep-alive
echo "== record 2 s at 1 kHz";            "$pamctl" record "$work/run.csv" --duration 2 --stats --quiet --keep-alive
echo "== disarm";                         "$pamctl" disarm
"$pamctl" status | grep -E '^(state|sample)'

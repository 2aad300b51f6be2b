#!/usr/bin/env bash
# The main job. Today: the robot model's torque/stiffness capability at a pose
# (extra arguments go to `pamctl model capability`, e.g. --alpha1-deg 10 --alpha2-deg 6.5).
set -euo pipefail
cd "$(dirname "$0")"
exec cargo run --quiet --release -p pamctl -- model capability "$@"

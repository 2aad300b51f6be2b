#!/usr/bin/env bash
# Every test of the project, on a fresh machine: installs what is missing (the pinned Rust
# toolchain and its thumbv7em-none-eabihf target through rustup; qemu-system-arm through
# apt-get when run as root), then runs the host suite and the Cortex-M4F suite in QEMU.
# Closes with one line per suite: `host: N passed, M failed` and `qemu: N passed, M failed`.
# Runs from any directory; a relative CARGO_TARGET_DIR is relative to the directory it is
# run from (made absolute here, before moving to the repository).
set -euo pipefail
if [ -n "${CARGO_TARGET_DIR:-}" ] && [ "${CARGO_TARGET_DIR#/}" = "$CARGO_TARGET_DIR" ]; then
  CARGO_TARGET_DIR="$PWD/$CARGO_TARGET_DIR"
fi
cd "$(dirname "$0")"

if ! command -v cargo >/dev/null 2>&1; then
  echo "cargo not found: install rustup (https://rustup.rs), then run ./test.sh again" >&2
  exit 1
fi
# rust-toolchain.toml pins the toolchain; this makes rustup fetch it and the target now.
rustup show active-toolchain >/dev/null
rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 || true

exec cargo xtask test

#!/usr/bin/env bash
# Runs the whole test suite on virtual time (no hardware needed). Installs missing
# system packages first.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo test --workspace --locked "$@"

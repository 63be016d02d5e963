#!/usr/bin/env bash
# Opens the station on the built-in simulated vehicle. Installs missing system packages first.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
exec cargo run --release --locked -p topside -- "$@"

#!/usr/bin/env bash
# Runs every test of the workspace. The test profile is optimised (Cargo.toml), so the long property and
# stability tests (10^6 moves, 10^6 links) take seconds.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace "$@"

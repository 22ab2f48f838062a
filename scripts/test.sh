#!/usr/bin/env bash
# The README's second command (and CI's): installs what is missing, builds Release with tests and
# runs the whole suite through CTest. Set MFPC_PRESET=asan (or debug) for another preset.
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${MFPC_PRESET:-release}"

bash scripts/install-deps.sh
cmake --preset "$preset"
cmake --build --preset "$preset"
ctest --preset "$preset"

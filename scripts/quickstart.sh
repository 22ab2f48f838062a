#!/usr/bin/env bash
# The README's first command: installs what is missing, builds Release and runs the main job, which
# needs no input: `mfpc demo` synthesizes a tabletop scene with ground truth, recognizes its cartons
# with and without multifoveation, prints the comparison and writes out/demo/ (with demo.png).
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-deps.sh
cmake --preset release
cmake --build --preset release --target mfpc_cli
build/release/tools/mfpc --json out/demo.json demo -o out/demo
echo
echo "quickstart: wrote out/demo/ (scene, ground truth, labels, models, demo.png) and out/demo.json"

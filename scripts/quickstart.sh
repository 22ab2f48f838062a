#!/usr/bin/env bash
# The README's first command: installs what is missing, builds Release and runs the main job on the
# built-in procedural tabletop scene (no input needed): multifoveation with redundancy treatment,
# one foveated structure per object. Writes out/foveated.pcd and out/foveate.json.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-deps.sh
cmake --preset release
cmake --build --preset release --target mfpc_cli
mkdir -p out
build/release/tools/mfpc --json out/foveate.json foveate --procedural -o out/foveated.pcd
echo
echo "quickstart: wrote out/foveated.pcd and out/foveate.json"

#!/usr/bin/env bash
# Installs MFPC's build and test dependencies from Debian 12 packages.
# Idempotent: installs only what is missing and does nothing when all is present.
# Runs as root, or through sudo when not root.
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config
  libtbb-dev libeigen3-dev libopenvdb-dev libflann-dev libpcl-dev libembree-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev nlohmann-json3-dev libpng-dev gnuplot-nox
  clang libclang-rt-14-dev  # scripts/fuzz.sh: the fuzz preset (clang 14, libFuzzer, ASan, UBSan)
  jq  # scripts/compare-outputs.sh
  libopenmpi-dev openmpi-bin  # mfpc batch under mpirun
  libopen3d-dev  # bench/ only: the Open3D baseline of bench_baselines
  doxygen  # the docs target: the API reference from the public headers
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$'; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "install-deps: not root and no sudo; install: ${missing[*]}" >&2; exit 1; }
  sudo=(sudo)
fi

echo "install-deps: installing ${missing[*]}"
# Passed through env: sudo resets the environment.
"${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq
"${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"

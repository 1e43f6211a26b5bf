#!/usr/bin/env bash
# Installs the Debian packages pcl_ecs needs (skips what is already installed).
# scripts/install_deps.sh [--tools]: --tools installs only what building the tools needs.
set -euo pipefail
# What the tools need (scripts/quickstart.sh installs only these: --tools) ...
pkgs=(
  build-essential cmake ninja-build pkg-config
  libpcl-dev libeigen3-dev libflann-dev libboost-dev
  libopenmpi-dev            # Debian's VTK config (pulled in by PCL) needs MPI's C target
  libnanoflann-dev          # the fast K-d tree behind our PCL search back end
  libyaml-cpp-dev           # ecs_node launch files
  nlohmann-json3-dev        # the tools' JSON (--stats, plans)
  libcgal-dev               # Cocone (pcd_simplify --mesh, pcd_reconstruct) and the benchmark peers
)
# ... and what the tests add (scripts/test.sh).
if [ "${1:-}" != "--tools" ]; then
  pkgs+=(
    git libgtest-dev
    pcl-tools                 # pcl_pcd2ply: the interop test reads our outputs with PCL's own tools
    clang libclang-rt-14-dev  # libFuzzer for the loader fuzz target
    python3 python3-venv      # the Python tests run in a venv (tests/python/requirements.txt)
    xvfb xauth libgl1-mesa-dri  # offscreen screenshots of the viewer (tests and README pictures)
  )
fi
# cargo builds the LAZ codec (rust/ecs_laz); rustup's, when the machine has it, else Debian's.
if ! command -v cargo >/dev/null 2>&1 && [ ! -x "$HOME/.cargo/bin/cargo" ]; then
  pkgs+=(cargo)
fi
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all packages present"
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; fi
echo "install_deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install_deps: done"

#!/usr/bin/env bash
# Idempotent setup for a fresh Debian 12 machine: apt-get update, Debian packages, configure, build.
# Safe to run again: apt skips what is installed and CMake rebuilds only what changed.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

packages=(
  build-essential cmake pkg-config
  libeigen3-dev libmujoco-dev libosmesa6-dev libtinyxml2-dev liblodepng-dev libcli11-dev
  libbenchmark-dev libgtest-dev googletest zlib1g-dev nlohmann-json3-dev
  ffmpeg python3-matplotlib
  python3-dev pybind11-dev python3-pybind11 python3-numpy python3-pytest python3-venv python3-pip
  clang libclang-rt-14-dev
)
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null

build_dir=${DDOC_BUILD_DIR:-"$here/build"}
cmake -S "$here" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build_dir" -j"$(nproc)"

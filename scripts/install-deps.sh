#!/usr/bin/env bash
# install every Debian package stance needs; idempotent, skips what is installed.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libmujoco-dev libmujoco-samples libqhull-dev
  libdart-all-dev libdart-external-ikfast-dev dart-doc
  libeigen3-dev libyaml-cpp-dev libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libglfw3-dev libimgui-dev libgl-dev libegl-dev libosmesa6-dev
  gnuplot-nox ffmpeg xvfb xauth
  python3-dartpy
  python3-dev pybind11-dev python3-numpy python3-pytest
  libslicot-dev libtinyxml2-dev
  clang-14 libclang-rt-14-dev
  libopenmpi-dev openmpi-bin
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"

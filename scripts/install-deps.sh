#!/usr/bin/env bash
# Installs every build, test and run-time dependency of lensfx from Debian 12's packages.
# Idempotent: packages already present are left alone; apt's lists are refreshed only when needed.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libopenimageio-dev openimageio-tools libopenexr-dev
  libopencv-core-dev libopencv-imgproc-dev
  libopencolorio-dev
  libegl-dev libgl-dev libepoxy-dev libegl-mesa0 libgl1-mesa-dri mesa-utils
  libfftw3-dev
  libgtest-dev libgmock-dev
  libcli11-dev libtomlplusplus-dev nlohmann-json3-dev libfmt-dev
  ffmpeg
  clang-14 libclang-rt-14-dev
  slurm-wlm munge
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"

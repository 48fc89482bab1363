#!/usr/bin/env bash
# Installs the dependencies (Debian 12 packages) and builds lensfx into build/ (Release, warnings as errors).
# Extra arguments go to CMake's configure step.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DLENSFX_WERROR=ON "$@"
cmake --build build

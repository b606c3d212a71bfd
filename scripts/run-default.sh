#!/usr/bin/env bash
# run-default.sh — setup, Release build, then render the default scene
# (bunny on a ground plane, phong shading with shadows) to out/default.png
# and print the statistics.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
./scripts/setup.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)" --target splatgi-render
mkdir -p out
./build/splatgi-render --default --shade phong --out out/default.png --stats "$@"

#!/usr/bin/env bash
# Builds the pointfair tool and runs its main job on the built-in input: the paper's noisy
# octahedron, smoothed with the defaults and with the isotropic flow; PLY results, a picture and
# a summary in ./out.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
build=${POINTFAIR_BUILD_DIR:-build}
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$(nproc)" --target pointfair >/dev/null
"$build/tools/pointfair" demo --out out "$@"

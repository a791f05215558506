#!/usr/bin/env bash
# The quality benchmark in one command: builds pointfair_quality (with CGAL's smoothers as
# peers when libcgal-dev is installed), extracts the real models from Debian's libcgal-demo
# data if it is installed, and writes build/out/quality/report.md with its pictures.
#   bash bench/quality/run.sh [extra pointfair_quality options, e.g. --noise 0.1 --points 50000]
set -euo pipefail
cd "$(dirname "$0")/../.."
build=build/quality
out=build/out/quality
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPOINTFAIR_BUILD_TESTS=OFF -DPOINTFAIR_QUALITY_CGAL=ON >/dev/null
cmake --build "$build" --target pointfair_quality -j"$(nproc)"
mkdir -p "$out/data"
data_args=()
archive=/usr/share/doc/libcgal-dev/data.tar.gz
if [ -f "$archive" ]; then
  tar -xzf "$archive" -C "$out/data" --strip-components=2 \
    data/meshes/fandisk.off data/meshes/joint.off data/meshes/bunny00.off
  data_args=(--data "$out/data")
else
  echo "quality: $archive not found (apt-get install libcgal-demo): real models skipped" >&2
fi
"$build/bench/quality/pointfair_quality" --out "$out" "${data_args[@]}" "$@"

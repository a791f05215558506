#!/usr/bin/env bash
# The quality benchmark in one command: builds pointfair_quality (with CGAL's smoothers and
# PCL's MLS as peers when libcgal-dev / libpcl-dev are installed; MeshLab's RIMLS and APSS run
# when meshlabserver and xvfb-run are on the PATH), extracts the real models from Debian's
# libcgal-demo data if it is installed, and writes build/out/quality/report.md with its pictures.
#   bash bench/quality/run.sh [extra pointfair_quality options, e.g. --noise 0.1 --points 50000]
# Peers: apt-get install libcgal-dev libcgal-demo libpcl-dev meshlab xvfb xauth.
# Options (all passed to pointfair_quality; `--help` lists them):
#   --no-paper                  skip the paper's experiments (Figures 1-7)
#   --models a,b / --points N   the meshes (default fandisk,joint,bunny00) and their samples
#   --shapes a,b / --shape-points N   the analytic shapes (default sphere,torus at 20000)
#   --noise 0.1,0.5,1           noise levels, % of the diagonal
#   --thin-sigmas S / --thin-points N  the thin plate (sides S noise sigmas apart; 0: none)
#   --no-cgal, --no-pcl, --no-meshlab  leave a peer out
#   --pcl-radii 2,3,4,6,8,12,16 PCL MLS radii in mean sample spacings
#   --meshlab-k 32 / --meshlab-scales 2,3,4,6,8,12   MeshLab's normals' K and filter scales
# POINTFAIR_QUALITY_JOBS (default: the number of cores) sets the build's parallel jobs.
set -euo pipefail
cd "$(dirname "$0")/../.."
build=build/quality
out=build/out/quality
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPOINTFAIR_BUILD_TESTS=OFF -DPOINTFAIR_QUALITY_CGAL=ON \
  -DPOINTFAIR_QUALITY_PCL=ON >/dev/null
cmake --build "$build" --target pointfair_quality -j"${POINTFAIR_QUALITY_JOBS:-$(nproc)}"
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

#!/usr/bin/env bash
# Submits import -> smooth -> export as a chain of Slurm jobs: each starts only when the
# previous one ended successfully (--dependency=afterok), and a failed job cancels the rest
# (--kill-on-invalid-dep). Prints the three job ids.
#
#   tools/slurm/pipeline.sh SCAN WORKDIR RESULT [pointfair_mpi smooth options]
#   tools/slurm/pipeline.sh scan.las /scratch/me/scan smoothed.ply --steps 50 --memory-budget 48G
#   tools/slurm/pipeline.sh tiles/ /scratch/me/scan smoothed/ --memory-budget 48G
#
# SCAN may be a folder of tiles (every .las .laz .ply .xyz file in it, as one cloud): RESULT is
# then a folder of the same files (`pointfair export RUN RESULT --files SCAN`).
#
# import runs `pointfair_mpi import` on POINTFAIR_IMPORT_NODES nodes (each rank reads its
# share of a binary PLY or LAS file; rank 0 reads text files alone); smooth runs smooth.sbatch
# on POINTFAIR_NODES nodes; export is one task (`pointfair export`, streaming within its
# memory). WORKDIR must be on a file system every node sees.
# Environment: POINTFAIR (the serial CLI, default pointfair), POINTFAIR_MPI (default
# pointfair_mpi), POINTFAIR_NODES (default 4), POINTFAIR_IMPORT_NODES (default 1),
# POINTFAIR_TILE_BUDGET (import's --memory-budget: the tile size and its own memory; default
# 2G), POINTFAIR_IMPORT_OPTIONS (more import options, e.g. "--tile-points 3000000"), POINTFAIR_LAUNCH (how import and smooth start their ranks; default
# "srun --kill-on-bad-exit=1"), POINTFAIR_EXPORT_MEM (Slurm --mem of export; default 0, a
# whole node's), SBATCH_EXTRA (e.g. "-p long -A proj").
set -euo pipefail
if [ $# -lt 3 ]; then
  echo "usage: pipeline.sh SCAN WORKDIR RESULT [smooth options]" >&2
  exit 2
fi
scan=$1
work=$2
result=$3
shift 3
here=$(cd "$(dirname "$0")" && pwd)
cli=${POINTFAIR:-pointfair}
mpi=${POINTFAIR_MPI:-pointfair_mpi}
launch=${POINTFAIR_LAUNCH:-srun --kill-on-bad-exit=1}
read -r -a extra <<< "${SBATCH_EXTRA:-}"
# smooth.sbatch reads these (sbatch passes the environment on).
export POINTFAIR_MPI=$mpi POINTFAIR_LAUNCH=$launch
mkdir -p "$work"
container="$work/scan.h5"
run="$work/run.h5"

# $launch is split into words on purpose (a launcher and its options).
read -r -a import_options <<< "${POINTFAIR_IMPORT_OPTIONS:-}"
import_cmd="$launch $(printf '%q ' "$mpi" import "$scan" "$container" --memory-budget "${POINTFAIR_TILE_BUDGET:-2G}" \
  "${import_options[@]}")"
import=$(sbatch --parsable "${extra[@]}" --job-name=pointfair-import --nodes="${POINTFAIR_IMPORT_NODES:-1}" \
  --ntasks-per-node=1 --exclusive --output="$work/%x-%j.log" --wrap "$import_cmd")
smooth=$(sbatch --parsable "${extra[@]}" --dependency="afterok:$import" --kill-on-invalid-dep=yes \
  --nodes="${POINTFAIR_NODES:-4}" --output="$work/%x-%j.log" "$here/smooth.sbatch" "$container" "$run" "$@")
# A folder of tiles (docs/tiles-folder.md) comes back as a folder of the same files.
if [ -d "$scan" ]; then
  export_cmd=$(printf '%q ' "$cli" export "$run" "$result" --files "$scan")
else
  export_cmd=$(printf '%q ' "$cli" export "$run" "$result" --attributes)
fi
export=$(sbatch --parsable "${extra[@]}" --dependency="afterok:$smooth" --kill-on-invalid-dep=yes \
  --job-name=pointfair-export --ntasks=1 --exclusive --mem="${POINTFAIR_EXPORT_MEM:-0}" \
  --output="$work/%x-%j.log" --wrap "$export_cmd")
echo "import $import -> smooth $smooth -> export $export"

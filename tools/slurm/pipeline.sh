#!/usr/bin/env bash
# Submits import -> smooth -> export as a chain of Slurm jobs: each starts only when the
# previous one ended successfully (--dependency=afterok). Prints the three job ids.
#
#   tools/slurm/pipeline.sh SCAN WORKDIR RESULT [pointfair_mpi smooth options]
#   tools/slurm/pipeline.sh scan.las /scratch/me/scan smoothed.ply --steps 50 --memory-budget 48G
#
# import and export run as one task each (they stream within their --memory-budget);
# smooth runs smooth.sbatch on POINTFAIR_NODES nodes.
# Environment: POINTFAIR (the serial CLI, default pointfair), POINTFAIR_MPI, POINTFAIR_NODES
# (default 4), POINTFAIR_TILE_BUDGET (import's --memory-budget: the tile size and its own
# memory; default 2G), POINTFAIR_IMPORT_MEM (Slurm --mem of import and export; default 0, a
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
read -r -a extra <<< "${SBATCH_EXTRA:-}"
mkdir -p "$work"
container="$work/scan.h5"
run="$work/run.h5"

import_cmd=$(printf '%q ' "$cli" import "$scan" "$container" --memory-budget "${POINTFAIR_TILE_BUDGET:-2G}")
import=$(sbatch --parsable "${extra[@]}" --job-name=pointfair-import --ntasks=1 --exclusive \
  --mem="${POINTFAIR_IMPORT_MEM:-0}" --output="$work/%x-%j.log" --wrap "$import_cmd")
smooth=$(sbatch --parsable "${extra[@]}" --dependency="afterok:$import" --nodes="${POINTFAIR_NODES:-4}" \
  --output="$work/%x-%j.log" "$here/smooth.sbatch" "$container" "$run" "$@")
export_cmd=$(printf '%q ' "$cli" export "$run" "$result" --attributes)
export=$(sbatch --parsable "${extra[@]}" --dependency="afterok:$smooth" --job-name=pointfair-export --ntasks=1 \
  --exclusive --mem="${POINTFAIR_IMPORT_MEM:-0}" --output="$work/%x-%j.log" --wrap "$export_cmd")
echo "import $import -> smooth $smooth -> export $export"

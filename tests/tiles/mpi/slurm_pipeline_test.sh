#!/usr/bin/env bash
# tools/slurm/pipeline.sh and smooth.sbatch against stand-ins of sbatch and srun: sbatch runs
# each job at once (a job whose afterok dependency did not end with 0 never runs), srun starts
# the job's tasks with mpirun. The chain import (2 ranks) -> smooth (2 ranks) -> export must
# give the PLY file of the single-process pointfair import / smooth / export, byte for byte;
# a failing import must leave smooth and export unrun.
#   slurm_pipeline_test.sh SOURCE_DIR POINTFAIR POINTFAIR_MPI MPIEXEC
set -euo pipefail
src=$1
cli=$2
mpi=$3
mpiexec=$4
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
mkdir "$dir/bin" "$dir/jobs"
echo 100 > "$dir/jobs/next"

cat > "$dir/bin/sbatch" <<'STANDIN'
#!/usr/bin/env bash
# Stand-in sbatch: checks the options, runs the job now, prints its id (--parsable).
set -euo pipefail
wrap='' script='' dep='' nodes=1
while [ $# -gt 0 ]; do
  case $1 in
    --wrap) wrap=$2; shift 2 ;;
    --dependency=*) dep=${1#--dependency=}; shift ;;
    --nodes=*) nodes=${1#--nodes=}; shift ;;
    --parsable|--exclusive|--kill-on-invalid-dep=yes|--job-name=*|--output=*|--ntasks=1|--ntasks-per-node=1|--mem=*) shift ;;
    -*) echo "sbatch stand-in: unexpected option $1" >&2; exit 1 ;;
    *) script=$1; shift; break ;;
  esac
done
id=$(cat "$FAKE_SLURM/next")
echo $((id + 1)) > "$FAKE_SLURM/next"
echo "$id"
if [ -n "$dep" ]; then
  case $dep in afterok:*) ;; *) echo "sbatch stand-in: unexpected dependency $dep" >&2; exit 1 ;; esac
  if [ "$(cat "$FAKE_SLURM/${dep#afterok:}")" != 0 ]; then echo never > "$FAKE_SLURM/$id"; exit 0; fi
fi
export SLURM_JOB_ID=$id SLURM_NNODES=$nodes SLURM_NTASKS=$nodes SLURM_CPUS_PER_TASK=1
rc=0
if [ -n "$wrap" ]; then
  sh -c "$wrap" > "$FAKE_SLURM/$id.log" 2>&1 || rc=$?
else
  bash "$script" "$@" > "$FAKE_SLURM/$id.log" 2>&1 || rc=$?
fi
echo "$rc" > "$FAKE_SLURM/$id"
STANDIN

cat > "$dir/bin/srun" <<'STANDIN'
#!/usr/bin/env bash
# Stand-in srun: one rank per task through mpirun; records the cores per task it was given
# (SRUN_CPUS_PER_TASK, which srun takes instead of the job's --cpus-per-task since 22.05).
set -euo pipefail
while [ $# -gt 0 ]; do
  case $1 in
    --kill-on-bad-exit=1) shift ;;
    -*) echo "srun stand-in: unexpected option $1" >&2; exit 1 ;;
    *) break ;;
  esac
done
echo "${SRUN_CPUS_PER_TASK:-unset}" > "$FAKE_SLURM/$SLURM_JOB_ID.srun_cpus"
exec "$MPIEXEC" --oversubscribe -np "$SLURM_NTASKS" "$@"
STANDIN
chmod +x "$dir/bin/sbatch" "$dir/bin/srun"

export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
"$cli" generate sphere "$dir/scan.ply" --points 4000 --noise 0.2 > /dev/null 2>&1
steps=(--steps 3)

# The single-process reference.
"$cli" import "$dir/scan.ply" "$dir/ref.h5" --memory-budget 16M --tile-points 700 --quiet
"$cli" smooth "$dir/ref.h5" "$dir/ref_run.h5" "${steps[@]}" --threads 1 > /dev/null 2>&1
"$cli" export "$dir/ref_run.h5" "$dir/ref.ply" --attributes > /dev/null 2>&1

run_pipeline() {
  PATH="$dir/bin:$PATH" FAKE_SLURM="$dir/jobs" MPIEXEC="$mpiexec" POINTFAIR="$cli" POINTFAIR_MPI="$mpi" \
    POINTFAIR_NODES=2 POINTFAIR_IMPORT_NODES=2 POINTFAIR_TILE_BUDGET=16M POINTFAIR_IMPORT_OPTIONS="--tile-points 700" \
    bash "$src/tools/slurm/pipeline.sh" "$@"
}
line=$(run_pipeline "$dir/scan.ply" "$dir/work" "$dir/result.ply" "${steps[@]}")
echo "$line"
[ "$line" = "import 100 -> smooth 101 -> export 102" ] || { echo "FAIL: job ids: $line"; exit 1; }
for job in 100 101 102; do
  [ "$(cat "$dir/jobs/$job")" = 0 ] || { echo "FAIL: job $job ended with $(cat "$dir/jobs/$job")"; cat "$dir/jobs/$job.log"; exit 1; }
done
grep -q "on 2 ranks" "$dir/jobs/101.log" || { echo "FAIL: smooth did not run on 2 ranks"; cat "$dir/jobs/101.log"; exit 1; }
grep -q "on 2 ranks" "$dir/jobs/100.log" || { echo "FAIL: import did not run on 2 ranks"; cat "$dir/jobs/100.log"; exit 1; }
[ "$(cat "$dir/jobs/101.srun_cpus")" = 1 ] || { echo "FAIL: smooth's srun without SRUN_CPUS_PER_TASK"; exit 1; }
cmp "$dir/ref.ply" "$dir/result.ply" || { echo "FAIL: the pipeline's result differs from the single process's"; exit 1; }

# A folder of tiles: the same chain, the folder's files back, as the single process gives them.
mkdir "$dir/tiles"
"$cli" generate sphere "$dir/tiles/a.ply" --points 2000 --noise 0.2 --seed 3 > /dev/null 2>&1
"$cli" generate sphere "$dir/tiles/b.ply" --points 2000 --noise 0.2 --seed 4 > /dev/null 2>&1
"$cli" import "$dir/tiles" "$dir/ref_tiles.h5" --memory-budget 16M --tile-points 700 --quiet
"$cli" smooth "$dir/ref_tiles.h5" "$dir/ref_tiles_run.h5" "${steps[@]}" --threads 1 > /dev/null 2>&1
"$cli" export "$dir/ref_tiles_run.h5" "$dir/ref_tiles" --files "$dir/tiles" > /dev/null 2>&1
line=$(run_pipeline "$dir/tiles" "$dir/work_tiles" "$dir/result_tiles" "${steps[@]}")
for job in $(echo "$line" | grep -o '[0-9][0-9]*'); do
  [ "$(cat "$dir/jobs/$job")" = 0 ] || { echo "FAIL: folder job $job ended with $(cat "$dir/jobs/$job")"; cat "$dir/jobs/$job.log"; exit 1; }
done
for f in a.ply b.ply; do
  cmp "$dir/ref_tiles/$f" "$dir/result_tiles/$f" || { echo "FAIL: the folder pipeline's $f differs from the single process's"; exit 1; }
done

# A failing import: smooth and export never run, no result.
run_pipeline "$dir/missing.ply" "$dir/work2" "$dir/result2.ply" "${steps[@]}" > /dev/null
[ "$(cat "$dir/jobs/106")" != 0 ] || { echo "FAIL: the import of a missing file succeeded"; exit 1; }
if [ "$(cat "$dir/jobs/107")" != never ] || [ "$(cat "$dir/jobs/108")" != never ]; then
  echo "FAIL: jobs ran after a failed import"
  exit 1
fi
[ ! -e "$dir/result2.ply" ] || { echo "FAIL: a result after a failed import"; exit 1; }
echo "PASS: import -> smooth -> export on 2 ranks equals the single process, byte for byte (a file and a folder)"

#!/usr/bin/env bash
# The whole test suite, in stages (each prints its wall time):
#   main       Release build (warnings as errors) of everything, the Python module included;
#              every test with ctest (the module's: Python.*, label python)
#   package    cmake --install into a prefix; tests/package (project(x CXX), find_package)
#              configured, built and run against it; the installed Python package imported
#   mpi        pointfair_mpi (OpenMPI + parallel HDF5) under mpirun: 1-4 ranks bit-identical
#              to the single-process run, failing ranks, resuming on other rank counts; the
#              import on 1-4 ranks; the Slurm scripts (shellcheck, a run against stand-ins)
#   asan       the whole suite again under AddressSanitizer + UndefinedBehaviorSanitizer (gcc
#              -O1), but for the repeats of the core tests against the OpenMP back end and on
#              the plain kernels (EulerStepPlainKernel), and the quality measurements
#              (FeatureScenes, CoarseLevel.RemovesHeavyNoise...: long runs of code the other
#              tests reach too)
#   tsan       ThreadSanitizer over the parallel kernels, the tile pipeline and the out-of-core
#              steps run through it: the core with the std::thread back end (TBB's and
#              libgomp's own internals are not instrumented in Debian's builds); only their
#              tests' files are built (pointfair_threading_tests, pointfair_tiled_threading_tests)
#   fuzz       libFuzzer (clang): each reader's fuzzer for POINTFAIR_FUZZ_SECONDS (default 10)
#              over the committed seeds, and every committed regression input once
# POINTFAIR_HARDENING=0 skips asan, tsan and fuzz; POINTFAIR_MPI_STAGE=0 skips mpi.
# POINTFAIR_FULL_HARDENING=1 is the longer run (before a release; not every push): every
# build without precompiled headers (so a missing #include shows), the whole of
# pointfair_core_tests under ThreadSanitizer too, and 60 s per fuzzer unless
# POINTFAIR_FUZZ_SECONDS says otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
build=${POINTFAIR_BUILD_DIR:-build}
jobs=$(nproc)
full=${POINTFAIR_FULL_HARDENING:-0}
no_pch=OFF
[ "$full" = 1 ] && no_pch=ON
config=(-DCMAKE_DISABLE_PRECOMPILE_HEADERS="$no_pch")
started=$SECONDS
stage_start=$SECONDS
stage() {
  [ -n "${stage_name:-}" ] && echo "test.sh: stage $stage_name took $((SECONDS - stage_start)) s"
  stage_name=$1
  stage_start=$SECONDS
  [ -n "$stage_name" ] && echo "test.sh: stage $stage_name"
  return 0
}

stage main
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPOINTFAIR_WERROR=ON "${config[@]}" >/dev/null
cmake --build "$build" -j"$jobs"
ctest --test-dir "$build" --output-on-failure -j"$jobs" --timeout 600

stage package
# The C++ package as the README uses it: installed into a prefix, then a C++-only project
# (tests/package) configures with find_package(pointfair), builds and runs.
package="$build-package"
rm -rf "$package"
cmake --install "$build" --prefix "$package/prefix" >/dev/null
cmake -S tests/package -B "$package/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$PWD/$package/prefix" >/dev/null
cmake --build "$package/consumer"
mkdir -p "$package/run"
"$package/consumer/consumer" "$package/run"
# The Python package as docs/python.md installs it, imported from the prefix (not the build).
if grep -q '^POINTFAIR_PYTHON:BOOL=ON' "$build/CMakeCache.txt"; then
  python=$(sed -n 's/^Python3_EXECUTABLE:FILEPATH=//p' "$build/CMakeCache.txt")
  (cd "$package" && PYTHONPATH="$PWD/prefix/lib/python3/dist-packages" "$python" -c \
    'import numpy, pointfair; assert pointfair.smooth(numpy.random.default_rng(1).normal(size=(300, 3)), steps=2).shape == (300, 3)')
fi

if [ "${POINTFAIR_MPI_STAGE:-1}" != 0 ]; then
  stage mpi
  mpi="$build-mpi"
  cmake -S . -B "$mpi" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPOINTFAIR_WERROR=ON \
    -DPOINTFAIR_MPI=ON -DPOINTFAIR_BUILD_BENCH=OFF "${config[@]}" >/dev/null
  cmake --build "$mpi" -j"$jobs" --target pointfair_mpi pointfair_mpi_tests
  shellcheck tools/slurm/pipeline.sh tools/slurm/smooth.sbatch tests/tiles/mpi/slurm_pipeline_test.sh
  OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    ctest --test-dir "$mpi" --output-on-failure -j"$jobs" --timeout 300 -L mpi
fi

if [ "${POINTFAIR_HARDENING:-1}" != 0 ]; then
  stage asan
  # -O1 without -Werror: the warnings were checked by the main build (gcc's
  # -Wmaybe-uninitialized differs by optimisation level).
  asan="$build-asan"
  cmake -S . -B "$asan" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" -DCMAKE_C_FLAGS_RELEASE="-O1 -DNDEBUG" \
    -DPOINTFAIR_BUILD_BENCH=OFF -DPOINTFAIR_TEST_OPENMP=OFF -DPOINTFAIR_SANITIZE=address,undefined \
    -DPOINTFAIR_PYTHON=OFF "${config[@]}" >/dev/null
  cmake --build "$asan" -j"$jobs"
  ASAN_OPTIONS=abort_on_error=1:detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    LSAN_OPTIONS=suppressions="$PWD/tests/sanitizers/lsan.supp":print_suppressions=0 \
    ctest --test-dir "$asan" --output-on-failure -j"$jobs" --timeout 600 -E '^(FeatureScenes\.|CoarseLevel\.RemovesHeavyNoise|EulerStepPlainKernel$)'

  stage tsan
  tsan="$build-tsan"
  cmake -S . -B "$tsan" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" -DCMAKE_C_FLAGS_RELEASE="-O1 -DNDEBUG" \
    -DPOINTFAIR_BUILD_BENCH=OFF -DPOINTFAIR_PARALLEL=Threads -DPOINTFAIR_SANITIZE=thread -DPOINTFAIR_PYTHON=OFF \
    "${config[@]}" >/dev/null
  cmake --build "$tsan" -j"$jobs" --target pointfair_threading_tests pointfair_pipeline_tests \
    pointfair_tiled_threading_tests
  TSAN_OPTIONS=halt_on_error=1 ctest --test-dir "$tsan" --output-on-failure -j"$jobs" --timeout 600 \
    -R '^((Threading\.(Parallel|Neighbo[a-z]*|SpatialOrder|EulerStep)|Pipeline)\.|TiledThreading\.TiledSmoothTest\.(OneAndTwoThreads|Pipelined|StreamedHalos|PositionsHeld|StepsWrittenInListOrder|TemporalBlocks)|TiledThreading\.TiledMomentumTest\.EveryStrategy)'
  if [ "$full" = 1 ]; then
    cmake --build "$tsan" -j"$jobs" --target pointfair_core_tests
    TSAN_OPTIONS=halt_on_error=1 "$tsan/tests/pointfair_core_tests"
  fi

  stage fuzz
  probe=$(mktemp -d)
  if command -v clang++ >/dev/null &&
     printf 'extern "C" int LLVMFuzzerTestOneInput(const char*, unsigned long) { return 0; }\n' |
       clang++ -x c++ -fsanitize=fuzzer - -o "$probe/fuzz_probe" 2>/dev/null; then
    rm -rf "$probe"
    fuzz="$build-fuzz"
    cmake -S . -B "$fuzz" -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" \
      -DPOINTFAIR_WERROR=ON -DPOINTFAIR_BUILD_TESTS=OFF -DPOINTFAIR_BUILD_BENCH=OFF -DPOINTFAIR_FUZZ=ON -DPOINTFAIR_PYTHON=OFF \
      -DPOINTFAIR_FUZZ_SECONDS="${POINTFAIR_FUZZ_SECONDS:-$([ "$full" = 1 ] && echo 60 || echo 10)}" \
      "${config[@]}" >/dev/null
    cmake --build "$fuzz" -j"$jobs" --target pointfair_fuzz_ply pointfair_fuzz_xyz pointfair_fuzz_las pointfair_fuzz_container
    ctest --test-dir "$fuzz" --output-on-failure -j"$jobs" --timeout 600
  else
    rm -rf "$probe"
    echo "test.sh: clang++ with libFuzzer not found: fuzz smoke run skipped" >&2
  fi
fi
stage ""
echo "test.sh: all stages passed in $((SECONDS - started)) s"

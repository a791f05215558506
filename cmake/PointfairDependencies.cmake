# Every dependency comes from Debian 12's packages (see tools/install-deps.sh).
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(nanoflann REQUIRED)
find_package(Threads REQUIRED)
# zlib compresses the PNG pictures of pointfair render.
find_package(ZLIB REQUIRED)
# The out-of-core container (pointfair::tiles) uses the HDF5 C library; FindHDF5 probes it
# with a C compiler.
enable_language(C)
if(POINTFAIR_MPI)
  # Parallel HDF5 (Debian: libhdf5-openmpi-dev, installed beside the serial one) and MPI.
  find_package(MPI REQUIRED COMPONENTS C)
  find_package(PkgConfig REQUIRED)
  pkg_check_modules(POINTFAIR_HDF5_PARALLEL IMPORTED_TARGET hdf5-openmpi)
  if(POINTFAIR_HDF5_PARALLEL_FOUND)
    add_library(HDF5::HDF5 INTERFACE IMPORTED)
    target_link_libraries(HDF5::HDF5 INTERFACE PkgConfig::POINTFAIR_HDF5_PARALLEL MPI::MPI_C)
  else()
    set(HDF5_PREFER_PARALLEL TRUE)
    find_package(HDF5 REQUIRED COMPONENTS C)
    if(NOT HDF5_IS_PARALLEL)
      message(FATAL_ERROR "POINTFAIR_MPI needs parallel HDF5 (Debian: libhdf5-openmpi-dev)")
    endif()
  endif()
else()
  find_package(HDF5 REQUIRED COMPONENTS C)
endif()

if(POINTFAIR_PARALLEL STREQUAL "TBB")
  find_package(TBB REQUIRED)
elseif(POINTFAIR_PARALLEL STREQUAL "OpenMP")
  find_package(OpenMP REQUIRED)
elseif(NOT POINTFAIR_PARALLEL STREQUAL "Threads")
  message(FATAL_ERROR "POINTFAIR_PARALLEL must be TBB, OpenMP or Threads, not '${POINTFAIR_PARALLEL}'")
endif()

if(POINTFAIR_BUILD_TESTS)
  find_package(GTest REQUIRED)
  find_package(OpenMP QUIET)  # the tests also run the core with the OpenMP back end
endif()
if(POINTFAIR_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()

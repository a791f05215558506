# Precompiled headers. Every file of the library includes Eigen (through types.hpp) and every
# test file also includes GoogleTest: parsing them was most of the compile time of a small
# file. Only headers those files include anyway (directly or through types.hpp) are
# precompiled. -DCMAKE_DISABLE_PRECOMPILE_HEADERS=ON turns them off.

# The library's targets: Eigen's Core and Geometry, as types.hpp includes them.
function(pointfair_precompile_eigen)
  foreach(target IN LISTS ARGN)
    target_precompile_headers(${target} PRIVATE <Eigen/Core> <Eigen/Geometry>)
  endforeach()
endfunction()

# Every target under `dir` (and its subdirectories) that links GoogleTest reuses the header
# precompiled once by `host`: GoogleTest, Eigen's Core and Geometry.
function(pointfair_precompile_tests host dir)
  get_directory_property(targets DIRECTORY ${dir} BUILDSYSTEM_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(libs ${target} LINK_LIBRARIES)
    if(NOT target STREQUAL host AND "GTest::gtest" IN_LIST libs)
      target_precompile_headers(${target} REUSE_FROM ${host})
    endif()
  endforeach()
  get_directory_property(subdirs DIRECTORY ${dir} SUBDIRECTORIES)
  foreach(subdir IN LISTS subdirs)
    pointfair_precompile_tests(${host} ${subdir})
  endforeach()
endfunction()

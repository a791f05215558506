include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS pointfair_core pointfair_io pointfair_tiles pointfair
  EXPORT pointfairTargets
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
# The headers of the installed libraries only: eval and render (the benchmark's scoring and
# the pictures) are not installed, nor is the MPI layer outside an MPI build.
set(pointfair_header_excludes PATTERN eval EXCLUDE PATTERN render EXCLUDE)
if(NOT POINTFAIR_MPI)
  list(APPEND pointfair_header_excludes PATTERN mpi_ranks.hpp EXCLUDE)
endif()
install(DIRECTORY include/pointfair DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} ${pointfair_header_excludes})
install(EXPORT pointfairTargets NAMESPACE pointfair::
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/pointfair)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/pointfairConfig.cmake.in
  ${PROJECT_BINARY_DIR}/pointfairConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/pointfair)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/pointfairConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/pointfairConfig.cmake
  ${PROJECT_BINARY_DIR}/pointfairConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/pointfair)

include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS pointfair_core pointfair_io pointfair_tiles pointfair
  EXPORT pointfairTargets
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY include/pointfair DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
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

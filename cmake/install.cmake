# Install rules and the CMake package: `cmake --install build --prefix P` installs
#   P/include/orpe/<stage>/*.h, P/lib/liborpe_<stage>.a, P/bin/orpe,
#   P/lib/cmake/orpe/{orpeConfig,orpeConfigVersion,orpeTargets}.cmake
# so that a consumer writes find_package(orpe) and target_link_libraries(app PRIVATE orpe::orpe).
# The project's warning flags are build-only (orpe_add_stage), never exported.
include(CMakePackageConfigHelpers)

get_property(_orpe_stages GLOBAL PROPERTY ORPE_STAGE_TARGETS)
foreach(_t ${_orpe_stages})
  string(REPLACE "orpe_" "" _export_name ${_t})
  set_target_properties(${_t} PROPERTIES EXPORT_NAME ${_export_name})
endforeach()

install(TARGETS orpe ${_orpe_stages} EXPORT orpeTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS orpe_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/src/orpe DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.h")

set(_orpe_cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/orpe)
install(EXPORT orpeTargets NAMESPACE orpe:: DESTINATION ${_orpe_cmake_dir})
configure_package_config_file(${CMAKE_CURRENT_SOURCE_DIR}/cmake/orpeConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/orpeConfig.cmake
                              INSTALL_DESTINATION ${_orpe_cmake_dir})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/orpeConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/orpeConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/orpeConfigVersion.cmake
        DESTINATION ${_orpe_cmake_dir})

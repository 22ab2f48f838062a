# The installed CMake package: find_package(MFPC CONFIG REQUIRED) gives mfpc::mfpc (every module)
# and mfpc::core, mfpc::index, mfpc::kernels, mfpc::recognition.
include(CMakePackageConfigHelpers)

add_library(mfpc INTERFACE)
add_library(mfpc::mfpc ALIAS mfpc)
target_link_libraries(mfpc INTERFACE mfpc_core mfpc_index mfpc_kernels mfpc_recognition)
set_target_properties(mfpc PROPERTIES EXPORT_NAME mfpc)
install(TARGETS mfpc EXPORT MFPCTargets)

set(MFPC_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/MFPC)
install(EXPORT MFPCTargets NAMESPACE mfpc:: DESTINATION ${MFPC_CMAKE_DIR})
configure_package_config_file(cmake/MFPCConfig.cmake.in ${CMAKE_CURRENT_BINARY_DIR}/MFPCConfig.cmake
                              INSTALL_DESTINATION ${MFPC_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/MFPCConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/MFPCConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/MFPCConfigVersion.cmake
        DESTINATION ${MFPC_CMAKE_DIR})

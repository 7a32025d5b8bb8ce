# Install rules' last part: the exported targets and the package config, so that another CMake project
# can use find_package(nnb CONFIG) and link nnb::ours and nnb::api. Included after the adapters are known.
include(CMakePackageConfigHelpers)
include(GNUInstallDirs)
set(NNB_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/nnb)

get_property(nnb_package_deps GLOBAL PROPERTY NNB_PACKAGE_DEPENDENCIES)
list(REMOVE_DUPLICATES nnb_package_deps)
set(NNB_PACKAGE_FIND_DEPENDENCIES "")
foreach(dep IN LISTS nnb_package_deps)
  string(APPEND NNB_PACKAGE_FIND_DEPENDENCIES "find_dependency(${dep})\n")
endforeach()
get_property(NNB_PACKAGE_ADAPTERS GLOBAL PROPERTY NNB_ADAPTER_NAMES)

install(EXPORT nnbTargets NAMESPACE nnb:: DESTINATION ${NNB_INSTALL_CMAKEDIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/nnbConfig.cmake.in ${PROJECT_BINARY_DIR}/nnbConfig.cmake
                              INSTALL_DESTINATION ${NNB_INSTALL_CMAKEDIR})
# 0.x: a new minor version may break the API.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/nnbConfigVersion.cmake VERSION ${PROJECT_VERSION}
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/nnbConfig.cmake ${PROJECT_BINARY_DIR}/nnbConfigVersion.cmake
              ${CMAKE_CURRENT_LIST_DIR}/FindNnbANN.cmake ${CMAKE_CURRENT_LIST_DIR}/FindNnbSpatialIndex.cmake
              ${CMAKE_CURRENT_LIST_DIR}/FindNnbOpenVDB.cmake
        DESTINATION ${NNB_INSTALL_CMAKEDIR})

# Debian installs OpenVDB's own Find module (FindOpenVDB.cmake, with those of its dependencies) beside its
# library rather than on CMake's module path. Finds that folder, then OpenVDB through it: the target
# OpenVDB::openvdb. Used by the build and installed with nnb's package config, so both find it the same way.
find_path(NNB_OPENVDB_MODULE_DIR FindOpenVDB.cmake
          PATHS /usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/cmake/OpenVDB /usr/lib/cmake/OpenVDB
                /usr/local/lib/cmake/OpenVDB)
if(NNB_OPENVDB_MODULE_DIR AND NOT TARGET OpenVDB::openvdb)
  set(_nnb_openvdb_module_path "${CMAKE_MODULE_PATH}")
  list(PREPEND CMAKE_MODULE_PATH "${NNB_OPENVDB_MODULE_DIR}")
  find_package(OpenVDB QUIET)
  set(CMAKE_MODULE_PATH "${_nnb_openvdb_module_path}")
  unset(_nnb_openvdb_module_path)
endif()
set(NNB_OPENVDB_TARGET_FOUND FALSE)
if(TARGET OpenVDB::openvdb)
  set(NNB_OPENVDB_TARGET_FOUND TRUE)
endif()
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(NnbOpenVDB REQUIRED_VARS NNB_OPENVDB_MODULE_DIR NNB_OPENVDB_TARGET_FOUND)

# libspatialindex ships no CMake config and no pkg-config file. Defines the imported target
# nnb_spatialindex; used by the build and installed with nnb's package config, so both find it the same way.
find_path(NNB_SPATIALINDEX_INCLUDE_DIR spatialindex/SpatialIndex.h)
find_library(NNB_SPATIALINDEX_LIBRARY spatialindex)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(NnbSpatialIndex REQUIRED_VARS NNB_SPATIALINDEX_LIBRARY NNB_SPATIALINDEX_INCLUDE_DIR)
if(NnbSpatialIndex_FOUND AND NOT TARGET nnb_spatialindex)
  add_library(nnb_spatialindex UNKNOWN IMPORTED)
  set_target_properties(nnb_spatialindex PROPERTIES IMPORTED_LOCATION "${NNB_SPATIALINDEX_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${NNB_SPATIALINDEX_INCLUDE_DIR}")
endif()

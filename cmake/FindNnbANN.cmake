# ANN ships no CMake config and no pkg-config file (Debian's library is libann.so). Defines the imported
# target nnb_ann; used by the build and installed with nnb's package config, so both find it the same way.
find_path(NNB_ANN_INCLUDE_DIR ANN/ANN.h)
find_library(NNB_ANN_LIBRARY ann)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(NnbANN REQUIRED_VARS NNB_ANN_LIBRARY NNB_ANN_INCLUDE_DIR)
if(NnbANN_FOUND AND NOT TARGET nnb_ann)
  add_library(nnb_ann UNKNOWN IMPORTED)
  set_target_properties(nnb_ann PROPERTIES IMPORTED_LOCATION "${NNB_ANN_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${NNB_ANN_INCLUDE_DIR}")
endif()

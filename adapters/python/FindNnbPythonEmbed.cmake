# pybind11's embedding target (pybind11::embed) over Debian's /usr/bin/python3, the interpreter that has numpy,
# SciPy, pykdtree and scikit-learn: a pyenv shim earlier on PATH would otherwise be found first (it fails
# to configure, or is an interpreter without numpy). PYTHON_EXECUTABLE or Python_EXECUTABLE choose another.
# Used by the build and installed with nnb's package config, so both find the same interpreter.
if(NOT DEFINED PYTHON_EXECUTABLE AND NOT DEFINED Python_EXECUTABLE AND EXISTS /usr/bin/python3)
  set(PYTHON_EXECUTABLE /usr/bin/python3 CACHE FILEPATH "Python interpreter embedded by the Python adapters")
  set(Python_EXECUTABLE /usr/bin/python3 CACHE FILEPATH "Python interpreter embedded by the Python adapters")
endif()
find_package(pybind11 CONFIG QUIET)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(NnbPythonEmbed REQUIRED_VARS pybind11_DIR PYTHON_EXECUTABLE)

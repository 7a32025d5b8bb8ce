# nnb_add_adapter(TARGET t NAMES a [b...] SOURCES s... [LIBS l...] [FIND "args"...])
# Adds one adapter target; each NAME must have a factory nnb::adapters::make_<NAME>(const Params&)
# defined in its sources. nnb_finish_registry() then generates the registry of all of them.
# LIBS are private: an adapter's only interface is the search API. Its users still link them (it is a
# static library), so the installed package config must find them again: each FIND entry is the argument
# list of one find_dependency() call there, e.g. FIND "flann 1.9 CONFIG".
include(GNUInstallDirs)

function(nnb_add_adapter)
  cmake_parse_arguments(A "" "TARGET" "NAMES;SOURCES;LIBS;FIND" ${ARGN})
  add_library(${A_TARGET} STATIC ${A_SOURCES})
  target_link_libraries(${A_TARGET} PUBLIC nnb_api PRIVATE ${A_LIBS})
  string(REGEX REPLACE "^nnb_" "" export_name "${A_TARGET}")
  set_target_properties(${A_TARGET} PROPERTIES EXPORT_NAME ${export_name})
  set_property(GLOBAL APPEND PROPERTY NNB_ADAPTER_TARGETS ${A_TARGET})
  set_property(GLOBAL APPEND PROPERTY NNB_ADAPTER_NAMES ${A_NAMES})
  set_property(GLOBAL APPEND PROPERTY NNB_PACKAGE_DEPENDENCIES ${A_FIND})
endfunction()

# Sets var to the x.y.z version of the installed Debian package, or "unknown": for libraries whose headers
# state none.
function(nnb_debian_package_version var package)
  set(version "unknown")
  find_program(NNB_DPKG_QUERY dpkg-query)
  if(NNB_DPKG_QUERY)
    execute_process(COMMAND ${NNB_DPKG_QUERY} -W -f=\${Version} ${package} OUTPUT_VARIABLE dpkg_version
                    RESULT_VARIABLE dpkg_result ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
    if(dpkg_result EQUAL 0 AND dpkg_version MATCHES "^([0-9]+\\.[0-9]+\\.[0-9]+)")
      set(version "${CMAKE_MATCH_1}")
    endif()
  endif()
  set(${var} "${version}" PARENT_SCOPE)
endfunction()

function(nnb_finish_registry)
  get_property(targets GLOBAL PROPERTY NNB_ADAPTER_TARGETS)
  get_property(names GLOBAL PROPERTY NNB_ADAPTER_NAMES)
  set(NNB_REGISTRY_DECLS "")
  set(NNB_REGISTRY_ENTRIES "")
  foreach(name IN LISTS names)
    string(APPEND NNB_REGISTRY_DECLS "std::unique_ptr<SearchIndex> make_${name}(const Params& params);\n")
    string(APPEND NNB_REGISTRY_ENTRIES "      {\"${name}\", &adapters::make_${name}},\n")
  endforeach()
  configure_file(${PROJECT_SOURCE_DIR}/cmake/registry.cpp.in ${CMAKE_CURRENT_BINARY_DIR}/registry.cpp @ONLY)
  add_library(nnb_adapters STATIC ${CMAKE_CURRENT_BINARY_DIR}/registry.cpp)
  target_link_libraries(nnb_adapters PUBLIC nnb_api ${targets})
  # nnb::api is this library rather than an INTERFACE target: the registry's code (make_adapter) has to
  # live in a library anyway, and linking it already brings the API and every adapter built.
  add_library(nnb::api ALIAS nnb_adapters)
  set_target_properties(nnb_adapters PROPERTIES EXPORT_NAME api)
  install(TARGETS nnb_adapters ${targets} EXPORT nnbTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  list(JOIN names ", " joined)
  message(STATUS "nnb: adapters built in: ${joined}")
endfunction()

# ctest script (cmake -P): a second build of the whole project (SOURCE_DIR) in WORK_DIR with the adapter
# folder ADAPTER_DIR added by NNB_EXTRA_ADAPTERS and no optional adapter; builds only test_cross_check
# and nns_query, runs the cross-check on ADAPTER (the adapter's name) and checks that nns_query --list --json,
# which Table 1 is made from, declares it.
# WORK_DIR is kept between runs: a rerun only rebuilds what changed.
foreach(var SOURCE_DIR ADAPTER_DIR ADAPTER WORK_DIR GENERATOR CXX_COMPILER BUILD_TYPE SANITIZE)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "NnbTestExternalAdapter.cmake: -D${var}=... is missing")
  endif()
endforeach()

function(nnb_run step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc COMMAND_ECHO STDOUT)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "external adapter test: ${step} failed (${rc})")
  endif()
endfunction()

# Every optional adapter off (read from their CMakeLists, so a new one is off too): what is under test is
# the way in from outside, and each library compiled here a second time would add minutes.
set(off "")
file(GLOB adapter_lists "${SOURCE_DIR}/adapters/*/CMakeLists.txt")
foreach(list_file ${adapter_lists})
  file(STRINGS "${list_file}" options REGEX "^option\\(NNB_WITH_[A-Z0-9_]+")
  foreach(line ${options})
    string(REGEX MATCH "NNB_WITH_[A-Z0-9_]+" option "${line}")
    list(APPEND off -D${option}=OFF)
  endforeach()
endforeach()
message(STATUS "external adapter test: ${off}")
nnb_run(configure ${CMAKE_COMMAND} -S "${SOURCE_DIR}" -B "${WORK_DIR}" -G "${GENERATOR}"
        "-DCMAKE_BUILD_TYPE=${BUILD_TYPE}" "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}" "-DNNB_SANITIZE=${SANITIZE}"
        "-DNNB_EXTRA_ADAPTERS=${ADAPTER_DIR}" ${off})
nnb_run(build ${CMAKE_COMMAND} --build "${WORK_DIR}" --target test_cross_check nns_query -j 2)
# A filter that matches nothing passes too: require that tests ran.
execute_process(COMMAND "${WORK_DIR}/tests/test_cross_check" "--gtest_filter=*/${ADAPTER}*"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
message(STATUS "test_cross_check:\n${out}")
if(NOT rc EQUAL 0 OR NOT out MATCHES "PASSED  \\] [1-9]")
  message(FATAL_ERROR "external adapter test: the cross-check of ${ADAPTER} failed or ran no test (exit ${rc})")
endif()

execute_process(COMMAND "${WORK_DIR}/bench/nns_query" --list --json RESULT_VARIABLE rc OUTPUT_VARIABLE adapters)
message(STATUS "nns_query --list --json:\n${adapters}")
if(NOT rc EQUAL 0 OR NOT adapters MATCHES "\n  \"${ADAPTER}\": {")
  message(FATAL_ERROR "external adapter test: nns_query --list --json (exit ${rc}) does not declare ${ADAPTER}")
endif()

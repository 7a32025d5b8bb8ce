# ctest script (cmake -P): installs the build BUILD_DIR into a fresh prefix under WORK_DIR, then configures,
# builds and runs examples/consumer (CONSUMER_DIR) against it with the build's generator and compiler.
# A sanitizer build needs nothing more: its installed nnb::api carries the sanitizer link flags.
foreach(var BUILD_DIR CONSUMER_DIR WORK_DIR GENERATOR CXX_COMPILER BUILD_TYPE)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "NnbTestConsumer.cmake: -D${var}=... is missing")
  endif()
endforeach()

function(nnb_run step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc COMMAND_ECHO STDOUT)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "consumer test: ${step} failed (${rc})")
  endif()
endfunction()

file(REMOVE_RECURSE "${WORK_DIR}")
nnb_run(install ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${WORK_DIR}/prefix")
nnb_run(configure ${CMAKE_COMMAND} -S "${CONSUMER_DIR}" -B "${WORK_DIR}/build" -G "${GENERATOR}"
        "-DCMAKE_BUILD_TYPE=${BUILD_TYPE}" "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}"
        "-DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix" -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON)
nnb_run(build ${CMAKE_COMMAND} --build "${WORK_DIR}/build" -j 2)
nnb_run(run "${WORK_DIR}/build/nnb_consumer")

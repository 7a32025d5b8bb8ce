# nnb_add_build_commit_target(NAME HEADER): a target that writes the commit the sources are built from into
# HEADER (see write_build_commit.cmake) at every build, not at configure time, which goes stale.
function(nnb_add_build_commit_target name header)
  add_custom_target(${name}
    COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${PROJECT_SOURCE_DIR} -DOUT=${header}
            -P ${CMAKE_CURRENT_FUNCTION_LIST_DIR}/write_build_commit.cmake
    BYPRODUCTS ${header}
    COMMENT "Stamping the build's git commit")
endfunction()

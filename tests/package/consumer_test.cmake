# Installs the current build into a scratch prefix, then configures, builds and runs the
# examples/consumer project against that prefix only (not the build tree).
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "command failed (${result}): ${ARGN}\n${output}")
  endif()
  message(STATUS "${output}")
endfunction()

run(${CMAKE_COMMAND} --install "${MFPC_BINARY_DIR}" --prefix "${WORK_DIR}/prefix")

# The package carries the public headers only: no internal (detail/) header, and no public one
# that includes one, which would not compile against the installed tree.
file(GLOB_RECURSE installed_headers "${WORK_DIR}/prefix/include/mfpc/*")
foreach(header IN LISTS installed_headers)
  if(header MATCHES "/detail/")
    message(FATAL_ERROR "internal header installed: ${header}")
  endif()
  file(STRINGS "${header}" includes_detail REGEX "#include \"mfpc/[a-z]+/detail/")
  if(includes_detail)
    message(FATAL_ERROR "${header} includes an internal header: ${includes_detail}")
  endif()
endforeach()
if(NOT installed_headers)
  message(FATAL_ERROR "no header installed under ${WORK_DIR}/prefix/include/mfpc")
endif()
run(${CMAKE_COMMAND} -S "${MFPC_EXAMPLE_DIR}/consumer" -B "${WORK_DIR}/build" -G "${GENERATOR}"
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release
    # A sanitized library needs a sanitized program (the ASan runtime must load first).
    "-DCMAKE_CXX_FLAGS=${CONSUMER_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${CONSUMER_FLAGS}")
run(${CMAKE_COMMAND} --build "${WORK_DIR}/build")
run("${WORK_DIR}/build/consumer" "${WORK_DIR}/roundtrip.pcd")

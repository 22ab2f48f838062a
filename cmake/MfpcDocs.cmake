# The `docs` target: the API reference of the public headers, built by Doxygen (Debian package
# `doxygen`) into ${CMAKE_BINARY_DIR}/docs/html. Not part of ALL: `cmake --build --preset release
# --target docs`. Every warning (an undocumented entity, parameter or return value, a malformed
# comment) fails the target, so the reference stays complete as the headers change.

# Folders whose headers make the reference, searched recursively for *.hpp: every module's public
# headers, with those of the tools' simulation and rendering sub-libraries (the cli has none);
# detail/ folders stay out (docs/Doxyfile.in).
set(MFPC_DOCS_INPUTS
  ${PROJECT_SOURCE_DIR}/core/include
  ${PROJECT_SOURCE_DIR}/index/include
  ${PROJECT_SOURCE_DIR}/kernels/include
  ${PROJECT_SOURCE_DIR}/recognition/include
  ${PROJECT_SOURCE_DIR}/tools/simulation/include
  ${PROJECT_SOURCE_DIR}/tools/rendering/include
  ${PROJECT_SOURCE_DIR}/tools/batch/include)

find_package(Doxygen QUIET)
if(DOXYGEN_FOUND)
  # Doxyfile lists: one quoted path per line.
  list(JOIN MFPC_DOCS_INPUTS "\" \\\n                         \"" MFPC_DOXYGEN_INPUT)
  set(MFPC_DOXYGEN_INPUT "\"${MFPC_DOXYGEN_INPUT}\"")
  list(JOIN MFPC_DOCS_INPUTS "\" \\\n                         \"" MFPC_DOXYGEN_STRIP)
  set(MFPC_DOXYGEN_STRIP "\"${MFPC_DOXYGEN_STRIP}\"")
  set(MFPC_DOXYGEN_OUTPUT "${CMAKE_BINARY_DIR}/docs")
  configure_file(${PROJECT_SOURCE_DIR}/docs/Doxyfile.in ${CMAKE_BINARY_DIR}/docs/Doxyfile @ONLY)
  add_custom_target(docs
    COMMAND Doxygen::doxygen ${CMAKE_BINARY_DIR}/docs/Doxyfile
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    COMMENT "API reference (Doxygen) into ${MFPC_DOXYGEN_OUTPUT}/html"
    VERBATIM)
else()
  add_custom_target(docs
    COMMAND ${CMAKE_COMMAND} -E echo
            "docs: Doxygen not found: install the Debian package 'doxygen' (scripts/install-deps.sh does)"
    COMMAND ${CMAKE_COMMAND} -E false
    VERBATIM)
endif()

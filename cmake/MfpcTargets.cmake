# Shared settings for every mfpc target.

add_library(mfpc_warnings INTERFACE)
target_compile_options(mfpc_warnings INTERFACE -Wall -Wextra -Wpedantic
  # GCC 12 reports -Wrestrict false positives inside libstdc++'s string concatenation at -O2/-O3
  # (GCC bug 105651, fixed in 13).
  $<$<AND:$<CXX_COMPILER_ID:GNU>,$<VERSION_LESS:$<CXX_COMPILER_VERSION>,13>>:-Wno-restrict>)

if(MFPC_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()

# The fuzz build instruments everything it compiles for libFuzzer's coverage (fuzzer-no-link: the
# libraries get the counters, only the fuzz targets link libFuzzer's main) and stops at the first
# ASan or UBSan report, so that each one is a finding with a reproducer.
if(MFPC_BUILD_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "MFPC_BUILD_FUZZ needs clang (libFuzzer): use the fuzz preset")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
                      -fno-omit-frame-pointer
                      -fsanitize-ignorelist=${PROJECT_SOURCE_DIR}/tests/fuzz/sanitizer_ignorelist.txt)
  add_link_options(-fsanitize=address,undefined)
endif()

include(GNUInstallDirs)
set(CMAKE_INSTALL_RPATH "$ORIGIN/../${CMAKE_INSTALL_LIBDIR}")

# mfpc_module(NAME SOURCES ... DEPENDS ... PRIVATE_DEPENDS ...)
# One library per module folder, exported as mfpc::NAME, public headers in NAME/include.
function(mfpc_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPENDS;PRIVATE_DEPENDS" ${ARGN})
  add_library(mfpc_${name} ${ARG_SOURCES})
  add_library(mfpc::${name} ALIAS mfpc_${name})
  set_target_properties(mfpc_${name} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME mfpc_${name}
                        VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR})
  target_include_directories(mfpc_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_compile_features(mfpc_${name} PUBLIC cxx_std_20)
  target_link_libraries(mfpc_${name} PUBLIC ${ARG_DEPENDS} PRIVATE ${ARG_PRIVATE_DEPENDS}
                        $<BUILD_INTERFACE:mfpc_warnings>)
  # A library's calls to its own exported functions (the neighbour grid's row lookups from its
  # queries, say) bind inside it and can be inlined, instead of going through the PLT in case
  # another library interposed them, which nobody may do to mfpc's internals.
  target_compile_options(mfpc_${name} PRIVATE $<$<CXX_COMPILER_ID:GNU,Clang>:-fno-semantic-interposition>)
  install(TARGETS mfpc_${name} EXPORT MFPCTargets
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  # detail/ holds internal headers shared between modules: never installed.
  install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} PATTERN detail EXCLUDE)
endfunction()

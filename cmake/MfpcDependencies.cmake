# Every dependency comes from a Debian 12 package; scripts/install-deps.sh installs them all.
# A missing one stops the configure with the package to install.
#
# The order matters: PCL's config drags in VTK, whose config defines TBB and MPI targets. Finding
# TBB or OpenVDB before PCL fails with "Some (but not all) targets in this export set were
# already defined".

macro(mfpc_require package debian_package)
  find_package(${package} ${ARGN} QUIET)
  if(NOT ${package}_FOUND)
    message(FATAL_ERROR "MFPC needs ${package}: install the Debian package '${debian_package}' "
                        "(scripts/install-deps.sh installs every dependency). ${${package}_NOT_FOUND_MESSAGE}")
  endif()
endmacro()

set(MFPC_NEED_PCL OFF)
if(MFPC_BUILD_TESTS OR MFPC_BUILD_BENCH)
  set(MFPC_NEED_PCL ON)
endif()

# MPI (C) before PCL: VTK's MPI lookup needs it, and the batch driver uses it.
if(MFPC_NEED_PCL OR MFPC_BUILD_TOOLS)
  find_package(MPI QUIET COMPONENTS C)
endif()
if(MFPC_NEED_PCL)
  mfpc_require(PCL libpcl-dev 1.13 COMPONENTS common io kdtree search features filters keypoints recognition)
endif()

mfpc_require(TBB libtbb-dev CONFIG)
mfpc_require(Eigen3 libeigen3-dev 3.3 NO_MODULE)

# Debian ships OpenVDB's find module (not a config) beside its other CMake files.
list(APPEND CMAKE_MODULE_PATH "/usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/cmake/OpenVDB")
mfpc_require(OpenVDB libopenvdb-dev)

mfpc_require(flann libflann-dev CONFIG)
mfpc_require(nlohmann_json nlohmann-json3-dev 3)

if(MFPC_BUILD_TOOLS)
  mfpc_require(CLI11 libcli11-dev CONFIG)
  mfpc_require(embree libembree-dev 3)
  mfpc_require(PNG libpng-dev)
endif()
if(MFPC_BUILD_TESTS)
  mfpc_require(GTest libgtest-dev CONFIG)
endif()
if(MFPC_BUILD_BENCH)
  mfpc_require(benchmark libbenchmark-dev CONFIG)
endif()

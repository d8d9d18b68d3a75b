# SylvaDeps.cmake -- optional dependencies, found once for the whole tree.
#
# Nothing here is needed by the header-only library itself (that needs only glm and Threads,
# found in the top-level CMakeLists). These are for the command line, the benchmarks and their
# peers. Each sets SYLVA_HAVE_<NAME> (ON/OFF) and says on one STATUS line whether it was found.
# To build without one that is installed, pass -DCMAKE_DISABLE_FIND_PACKAGE_<Package>=ON.
#
#   sylva_image        INTERFACE target for image I/O. Always exists, so users need no if();
#                      links OpenImageIO when found and defines SYLVA_HAVE_OIIO=1, else =0.
#   SYLVA_HAVE_OIIO    OpenImageIO (libopenimageio-dev)
#   SYLVA_HAVE_EMBREE  embree 3 (libembree-dev): target `embree`, a peer in the benchmarks
#   SYLVA_HAVE_TBB     oneTBB (libtbb-dev): target `TBB::tbb`
include_guard(GLOBAL)

# Drops include directories that do not exist from an imported target. Debian 12's
# OpenImageIO export names /usr/include/opencv4, which exists only with libopencv-dev; CMake
# refuses to generate when an imported target names a missing include directory.
function(sylva_drop_missing_include_dirs target)
  if(NOT TARGET ${target})
    return()
  endif()
  foreach(property INTERFACE_INCLUDE_DIRECTORIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES)
    get_target_property(dirs ${target} ${property})
    if(NOT dirs)
      continue()
    endif()
    set(kept "")
    foreach(dir IN LISTS dirs)
      # Keep generator expressions untouched: they cannot be checked at configure time.
      if(dir MATCHES "\\$<" OR IS_DIRECTORY "${dir}")
        list(APPEND kept "${dir}")
      endif()
    endforeach()
    set_property(TARGET ${target} PROPERTY ${property} "${kept}")
  endforeach()
endfunction()

# ---- OpenImageIO: image output of sylva-render -------------------------------------------
# Debian 12's Imath export (pulled in by OpenImageIO) names a Python module that is not installed
# and reports it on a STATUS line that looks like an error; hide STATUS output just for this call
# (a --log-level given on the command line still wins).
set(_sylva_log_level "${CMAKE_MESSAGE_LOG_LEVEL}")
set(CMAKE_MESSAGE_LOG_LEVEL NOTICE)
find_package(OpenImageIO CONFIG QUIET)
set(CMAKE_MESSAGE_LOG_LEVEL "${_sylva_log_level}")
unset(_sylva_log_level)
add_library(sylva_image INTERFACE)
if(TARGET OpenImageIO::OpenImageIO)
  set(SYLVA_HAVE_OIIO ON)
  sylva_drop_missing_include_dirs(OpenImageIO::OpenImageIO)
  sylva_drop_missing_include_dirs(OpenImageIO::OpenImageIO_Util)
  target_link_libraries(sylva_image INTERFACE OpenImageIO::OpenImageIO)
  target_compile_definitions(sylva_image INTERFACE SYLVA_HAVE_OIIO=1)
  message(STATUS "sylva: OpenImageIO ${OpenImageIO_VERSION} found (PNG/EXR output)")
else()
  set(SYLVA_HAVE_OIIO OFF)
  target_compile_definitions(sylva_image INTERFACE SYLVA_HAVE_OIIO=0)
  message(STATUS "sylva: OpenImageIO not found (apt install libopenimageio-dev): image output limited")
endif()

# ---- embree 3: peer in sylva-bench -------------------------------------------------------
find_package(embree 3 QUIET)
if(TARGET embree)
  set(SYLVA_HAVE_EMBREE ON)
  message(STATUS "sylva: embree ${embree_VERSION} found (benchmark peer)")
else()
  set(SYLVA_HAVE_EMBREE OFF)
  message(STATUS "sylva: embree 3 not found (apt install libembree-dev): benchmark peer off")
endif()

# ---- oneTBB: optional executor and benchmark peer ----------------------------------------
find_package(TBB QUIET)
if(TARGET TBB::tbb)
  set(SYLVA_HAVE_TBB ON)
  message(STATUS "sylva: TBB ${TBB_VERSION} found")
else()
  set(SYLVA_HAVE_TBB OFF)
  message(STATUS "sylva: TBB not found (apt install libtbb-dev): TBB executor off")
endif()

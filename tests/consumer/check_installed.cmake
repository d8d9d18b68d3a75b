# cmake -P script behind the test consumer.installed_package (see CMakeLists.txt beside it).
# Every step is fatal on failure, so the test fails at the first broken step and says which.
cmake_minimum_required(VERSION 3.22)

foreach(var SYLVA_BUILD_DIR SYLVA_PREFIX CONSUMER_SOURCE_DIR CONSUMER_BUILD_DIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_installed.cmake: -D${var}=... is required")
  endif()
endforeach()
if(NOT CONSUMER_CONFIG)
  set(CONSUMER_CONFIG Release)
endif()

function(step what)
  message(STATUS "consumer: ${what}")
  execute_process(COMMAND ${ARGN} COMMAND_ERROR_IS_FATAL ANY)
endfunction()

# Fresh prefix and build tree each time: stale headers from an older install, or a cached
# sylva_DIR, would hide exactly the mistakes this test exists to catch.
file(REMOVE_RECURSE "${SYLVA_PREFIX}" "${CONSUMER_BUILD_DIR}")

# The library's component only: the headers, SPIR-V and the package, not the tools (which need
# not be built for this test).
step("install ${SYLVA_BUILD_DIR} into ${SYLVA_PREFIX}"
     "${CMAKE_COMMAND}" --install "${SYLVA_BUILD_DIR}" --prefix "${SYLVA_PREFIX}" --config "${CONSUMER_CONFIG}"
     --component sylva_library)

set(generator_args "")
if(CONSUMER_GENERATOR)
  list(APPEND generator_args -G "${CONSUMER_GENERATOR}")
endif()
if(CONSUMER_CXX_COMPILER)
  list(APPEND generator_args "-DCMAKE_CXX_COMPILER=${CONSUMER_CXX_COMPILER}")
endif()
step("configure ${CONSUMER_SOURCE_DIR}"
     "${CMAKE_COMMAND}" -S "${CONSUMER_SOURCE_DIR}" -B "${CONSUMER_BUILD_DIR}" ${generator_args}
     "-DCMAKE_BUILD_TYPE=${CONSUMER_CONFIG}" "-DCMAKE_PREFIX_PATH=${SYLVA_PREFIX}"
     # Only the prefix may provide sylva: no user or system package registry.
     -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF
     # A sylva built with Vulkan must install a working vulkan component (sylva::vulkan and
     # sylva_add_spirv): the GPU half is then required, not skipped.
     "-DCONSUMER_REQUIRE_VULKAN=${CONSUMER_REQUIRE_VULKAN}")

# Prove the package came from our prefix, not from some other sylva installed on the machine.
file(STRINGS "${CONSUMER_BUILD_DIR}/CMakeCache.txt" sylva_dir REGEX "^sylva_DIR:")
string(REGEX REPLACE "^sylva_DIR:[A-Z]+=" "" sylva_dir "${sylva_dir}")
file(REAL_PATH "${SYLVA_PREFIX}" real_prefix)
file(REAL_PATH "${sylva_dir}" real_sylva_dir)
string(FIND "${real_sylva_dir}" "${real_prefix}/" at)
if(NOT at EQUAL 0)
  message(FATAL_ERROR "consumer: sylva was found in '${sylva_dir}', not under '${SYLVA_PREFIX}'")
endif()

step("build" "${CMAKE_COMMAND}" --build "${CONSUMER_BUILD_DIR}" --config "${CONSUMER_CONFIG}")

# Single-config generators put the executable in the build root, multi-config ones in <config>/.
function(consumer_executable name out_var)
  set(exe "${CONSUMER_BUILD_DIR}/${name}")
  if(NOT EXISTS "${exe}")
    set(exe "${CONSUMER_BUILD_DIR}/${CONSUMER_CONFIG}/${name}")
  endif()
  set(${out_var} "${exe}" PARENT_SCOPE)
endfunction()
consumer_executable(sylva_consumer exe)
step("run ${exe}" "${exe}")

# The GPU half: the user's shader compiled by the installed sylva_add_spirv, run on the device
# SYLVA_VULKAN_DEVICE picks (lavapipe with =cpu), compared with the host.
consumer_executable(sylva_consumer_gpu gpu_exe)
if(CONSUMER_REQUIRE_VULKAN AND NOT EXISTS "${gpu_exe}")
  message(FATAL_ERROR "consumer: the GPU half was not built (${gpu_exe} is missing)")
endif()
if(EXISTS "${gpu_exe}")
  step("run ${gpu_exe}" "${gpu_exe}")
endif()
message(STATUS "consumer: the installed package works")

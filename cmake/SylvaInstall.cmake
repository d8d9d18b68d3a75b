# SylvaInstall.cmake -- install rules and the CMake package, so that users can write
#   find_package(sylva 0.1 REQUIRED)                      # or COMPONENTS vulkan for the GPU side
#   target_link_libraries(app PRIVATE sylva::sylva)       # or sylva::vulkan
#   sylva_add_spirv(TARGET app NAME my_shader SOURCE my_shader.comp)   # with the vulkan component
# Included by the top-level CMakeLists only when sylva is the top-level project.
#
# Layout under the prefix:
#   include/sylva/...            the headers (C++ and the shared C++/GLSL subset)
#   include/sylva/shaders/*.comp compute shader entry points; they #include <sylva/shared/...>,
#                                so `glslangValidator -I<prefix>/include` compiles them
#   include/sylva/spirv/...      SPIR-V embedded as uint32 arrays (when the build made them)
#   lib/cmake/sylva/             sylvaConfig.cmake, sylvaConfigVersion.cmake, sylvaTargets.cmake,
#                                and with Vulkan: sylvaVulkanTargets.cmake (sylva::vulkan) and
#                                SylvaShaders.cmake (sylva_add_spirv against the installed headers)
#
# Every rule here is in the install component `sylva_library` (the headers and the package);
# the tools (sylva-render, the benchmarks) are in the default component. `cmake --install <build>
# --component sylva_library` installs the library alone, without building the tools.
include_guard(GLOBAL)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(SYLVA_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/sylva"
    CACHE STRING "Where sylvaConfig.cmake is installed, relative to the prefix")

install(TARGETS sylva EXPORT sylvaTargets COMPONENT sylva_library)
install(EXPORT sylvaTargets NAMESPACE sylva:: DESTINATION "${SYLVA_INSTALL_CMAKEDIR}"
        COMPONENT sylva_library)
# The Vulkan side is a separate export set: its targets file names Vulkan::Vulkan, which only
# exists where the Vulkan loader is found, and users of sylva::sylva alone must not need it.
set(SYLVA_INSTALLED_VULKAN OFF)
if(TARGET sylva_vulkan)
  set(SYLVA_INSTALLED_VULKAN ON)
  install(TARGETS sylva_vulkan sylva_spirv EXPORT sylvaVulkanTargets COMPONENT sylva_library)
  install(EXPORT sylvaVulkanTargets NAMESPACE sylva:: DESTINATION "${SYLVA_INSTALL_CMAKEDIR}"
          COMPONENT sylva_library)
  install(FILES "${PROJECT_SOURCE_DIR}/cmake/SylvaShaders.cmake" DESTINATION "${SYLVA_INSTALL_CMAKEDIR}"
          COMPONENT sylva_library)
endif()

install(DIRECTORY "${PROJECT_SOURCE_DIR}/include/sylva/"
        DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/sylva"
        COMPONENT sylva_library)
install(DIRECTORY "${PROJECT_SOURCE_DIR}/shaders/"
        DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/sylva/shaders"
        COMPONENT sylva_library
        FILES_MATCHING PATTERN "*.comp")
# The SPIR-V headers are build outputs: OPTIONAL, because a build without glslangValidator (or an
# install before the first build) has none, and that must not break the install of the headers.
install(DIRECTORY "${PROJECT_BINARY_DIR}/generated/sylva/spirv/"
        DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/sylva/spirv"
        OPTIONAL
        COMPONENT sylva_library)

configure_package_config_file(
  "${PROJECT_SOURCE_DIR}/cmake/sylvaConfig.cmake.in"
  "${PROJECT_BINARY_DIR}/sylvaConfig.cmake"
  INSTALL_DESTINATION "${SYLVA_INSTALL_CMAKEDIR}"
  PATH_VARS CMAKE_INSTALL_INCLUDEDIR)
# Header-only: the package fits any architecture, so no 32/64-bit check (ARCH_INDEPENDENT).
write_basic_package_version_file(
  "${PROJECT_BINARY_DIR}/sylvaConfigVersion.cmake"
  VERSION "${PROJECT_VERSION}"
  COMPATIBILITY SameMajorVersion
  ARCH_INDEPENDENT)
install(FILES "${PROJECT_BINARY_DIR}/sylvaConfig.cmake" "${PROJECT_BINARY_DIR}/sylvaConfigVersion.cmake"
        DESTINATION "${SYLVA_INSTALL_CMAKEDIR}"
        COMPONENT sylva_library)

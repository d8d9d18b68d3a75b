# SylvaStore.cmake -- sylva::store, the out-of-core brick store (include/sylva/store/): the
# header-only library plus LMDB (liblmdb-dev), zstd (libzstd-dev), lz4 (liblz4-dev) and xxHash
# (libxxhash-dev), found through pkg-config. Sets SYLVA_HAVE_STORE (ON/OFF); without them the
# store, sylva-store and their tests are left out with one STATUS line.
include_guard(GLOBAL)

find_package(PkgConfig QUIET)
set(SYLVA_HAVE_STORE OFF)
if(PkgConfig_FOUND)
  pkg_check_modules(SYLVA_LMDB QUIET IMPORTED_TARGET lmdb)
  pkg_check_modules(SYLVA_ZSTD QUIET IMPORTED_TARGET libzstd)
  pkg_check_modules(SYLVA_LZ4 QUIET IMPORTED_TARGET liblz4)
  pkg_check_modules(SYLVA_XXHASH QUIET IMPORTED_TARGET libxxhash)
  if(SYLVA_LMDB_FOUND AND SYLVA_ZSTD_FOUND AND SYLVA_LZ4_FOUND AND SYLVA_XXHASH_FOUND)
    set(SYLVA_HAVE_STORE ON)
  endif()
endif()

if(SYLVA_HAVE_STORE)
  add_library(sylva_store INTERFACE)
  add_library(sylva::store ALIAS sylva_store)
  target_link_libraries(sylva_store INTERFACE sylva::sylva PkgConfig::SYLVA_LMDB PkgConfig::SYLVA_ZSTD
                                              PkgConfig::SYLVA_LZ4 PkgConfig::SYLVA_XXHASH)
  message(STATUS "sylva: brick store on (LMDB ${SYLVA_LMDB_VERSION}, zstd ${SYLVA_ZSTD_VERSION}, "
                 "lz4 ${SYLVA_LZ4_VERSION}, xxHash ${SYLVA_XXHASH_VERSION})")
else()
  message(STATUS "sylva: brick store off (apt install liblmdb-dev libzstd-dev liblz4-dev libxxhash-dev)")
endif()

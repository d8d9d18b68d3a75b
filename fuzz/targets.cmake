# The fuzz targets (fuzz/NAME.cpp, harness in fuzz/harness/): read by fuzz/CMakeLists.txt,
# tests/fuzz_regressions and scripts/fuzz.sh. The store_* targets need sylva::store (LMDB, zstd,
# lz4, xxHash: scripts/deps.sh installs them); SYLVA_FUZZ_STORE_TARGETS names them.
set(SYLVA_FUZZ_TARGETS
    raw_name raw nrrd_attached nrrd_detached nrrd_gzip tf_text tf_json particles
    bih lod kd ikd octree octree_elements store_brick store_build_info)
set(SYLVA_FUZZ_STORE_TARGETS store_brick store_build_info)

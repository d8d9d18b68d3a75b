# The fuzz targets (fuzz/NAME.cpp, harness in fuzz/harness/): read by fuzz/CMakeLists.txt,
# tests/fuzz_regressions and scripts/fuzz.sh.
set(SYLVA_FUZZ_TARGETS
    raw_name raw nrrd_attached nrrd_detached nrrd_gzip tf_text tf_json particles
    bih lod kd ikd octree octree_elements)

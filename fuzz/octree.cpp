// libFuzzer entry point of fuzz_octree (harness: fuzz/harness/octree.hpp).
#include "harness/octree.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) { return sylva_fuzz::fuzz_octree(data, size); }

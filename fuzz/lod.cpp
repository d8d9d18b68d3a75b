// libFuzzer entry point of fuzz_lod (harness: fuzz/harness/structures.hpp).
#include "harness/structures.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) { return sylva_fuzz::fuzz_lod(data, size); }

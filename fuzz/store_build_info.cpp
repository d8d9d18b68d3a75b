// libFuzzer entry point of fuzz_store_build_info (harness: fuzz/harness/store.hpp).
#include "harness/store.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) { return sylva_fuzz::fuzz_store_build_info(data, size); }

// libFuzzer entry point of fuzz_raw_name (harness: fuzz/harness/readers.hpp).
#include "harness/readers.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) { return sylva_fuzz::fuzz_raw_name(data, size); }

// libFuzzer entry point of fuzz_nrrd_attached (harness: fuzz/harness/readers.hpp).
#include "harness/readers.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) { return sylva_fuzz::fuzz_nrrd_attached(data, size); }

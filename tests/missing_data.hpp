// tests/missing_data.hpp -- what a test does when the real data it needs (../shared/data) is missing.
//
// Missing data FAILS the test, naming the path: CI has the data, so a missing file is an error,
// never a silent pass. Someone without the data may set SYLVA_ALLOW_MISSING_DATA=1: then the
// test process exits with code 77, which ctest reports as "Skipped" for the tests registered
// with SKIP_RETURN_CODE 77 and the label "data" (the tests tagged [data]; `ctest -LE data`
// leaves them out). A skipped check is never counted as a passed one.
// SYLVA_TEST_DATA_DIR overrides the data directory compiled in as SYLVA_DATA_DIR (the tests of
// this behaviour point it at an empty directory).
#ifndef SYLVA_TESTS_MISSING_DATA_HPP
#define SYLVA_TESTS_MISSING_DATA_HPP

#include <catch2/catch.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace sylva::testdata {

/// ctest's SKIP_RETURN_CODE for tests whose data is missing and allowed to be.
inline constexpr int kSkipCode = 77;

/// The data directory: $SYLVA_TEST_DATA_DIR, else SYLVA_DATA_DIR (../shared/data).
inline std::filesystem::path dir() {
    const char* env = std::getenv("SYLVA_TEST_DATA_DIR");
    if (env != nullptr && *env != '\0') return env;
#ifdef SYLVA_DATA_DIR
    return SYLVA_DATA_DIR;
#else
    return "../shared/data";  // targets without SYLVA_DATA_DIR read no data
#endif
}

/// Called when `path` is missing: fails the test, or (SYLVA_ALLOW_MISSING_DATA=1) ends the
/// process with kSkipCode so that ctest reports the test as skipped.
inline void missing(const std::filesystem::path& path) {
    const char* allow = std::getenv("SYLVA_ALLOW_MISSING_DATA");
    if (allow != nullptr && std::string(allow) == "1") {
        std::printf("SKIPPED: missing test data %s (SYLVA_ALLOW_MISSING_DATA=1; exit code %d)\n", path.string().c_str(),
                    kSkipCode);
        std::fflush(stdout);
        std::_Exit(kSkipCode);
    }
    FAIL("missing test data " << path.string()
                              << " (set SYLVA_ALLOW_MISSING_DATA=1 to have ctest report such tests as skipped)");
}

/// Path of data file `name`; a missing file fails (or skips) the test.
inline std::filesystem::path require(const std::string& name) {
    std::filesystem::path p = dir() / name;
    if (!std::filesystem::exists(p)) missing(p);
    return p;
}

}  // namespace sylva::testdata

#endif  // SYLVA_TESTS_MISSING_DATA_HPP

// Helpers for the volume tests: a scratch folder, file writers, and the shared data folder.
#ifndef SYLVA_TESTS_VOLUME_TEST_UTIL_HPP
#define SYLVA_TESTS_VOLUME_TEST_UTIL_HPP

#include <catch2/catch.hpp>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include "../missing_data.hpp"

namespace volume_test {

/// A fresh folder under the system temp folder, removed with everything in it at scope exit.
class TempDir {
public:
    TempDir() {
        static std::atomic<int> counter{0};
        path_ = std::filesystem::temp_directory_path() /
                ("sylva_volume_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    [[nodiscard]] std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
    [[nodiscard]] const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
};

/// Writes `bytes` to `path` (creating its folder).
inline void write_file(const std::filesystem::path& path, const void* bytes, std::size_t n) {
    if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(static_cast<const char*>(bytes), static_cast<std::streamsize>(n));
    REQUIRE(out.good());
}
inline void write_file(const std::filesystem::path& path, const std::string& text) {
    write_file(path, text.data(), text.size());
}
template <class T>
void write_file(const std::filesystem::path& path, const std::vector<T>& values) {
    write_file(path, values.data(), values.size() * sizeof(T));
}

/// Bytes of a vector of trivially copyable values.
template <class T>
std::string as_bytes(const std::vector<T>& v) {
    return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

/// Path of a file in ../shared/data; a missing file fails the test naming the path, or with
/// SYLVA_ALLOW_MISSING_DATA=1 ends it as skipped (tests/missing_data.hpp). Never nullopt.
inline std::optional<std::filesystem::path> data_file(const std::string& name) { return sylva::testdata::require(name); }

}  // namespace volume_test

#endif  // SYLVA_TESTS_VOLUME_TEST_UTIL_HPP

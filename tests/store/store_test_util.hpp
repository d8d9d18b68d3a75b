// tests/store/store_test_util.hpp -- temporary directories for store tests.
#ifndef SYLVA_TESTS_STORE_UTIL_HPP
#define SYLVA_TESTS_STORE_UTIL_HPP

#include <atomic>
#include <filesystem>
#include <string>
#include <unistd.h>

namespace sylva::testing {

/// A fresh directory under the system temp directory, removed with everything in it on
/// destruction.
class TempDir {
public:
    TempDir() {
        static std::atomic<int> n{0};
        path_ = std::filesystem::temp_directory_path() /
                ("sylva-store-test-" + std::to_string(::getpid()) + "-" + std::to_string(n++));
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    [[nodiscard]] const std::filesystem::path& path() const { return path_; }
    [[nodiscard]] std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

private:
    std::filesystem::path path_;
};

}  // namespace sylva::testing

#endif

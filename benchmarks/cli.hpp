// benchmarks/cli.hpp -- the command-line pieces sylva-tables, sylva-volume-bench and
// sylva-kd-bench share: a usage error (exit status 2), an option's value, whole numbers in a
// range, and one of a fixed set of words.
#ifndef SYLVA_BENCH_CLI_HPP
#define SYLVA_BENCH_CLI_HPP

#include <cstddef>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

namespace bench_cli {

/// Bad usage: reported with the usage text and exit status 2.
struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// The value that follows option argv[i]; advances i past it.
inline std::string value_of(int& i, int argc, char** argv) {
    if (i + 1 >= argc) throw UsageError(std::string(argv[i]) + " needs a value");
    return argv[++i];
}

/// A whole number in 1..max.
inline std::size_t parse_count(const std::string& option, const std::string& text, std::size_t max) {
    char* end = nullptr;
    unsigned long v = std::strtoul(text.c_str(), &end, 10);
    if (text.empty() || text[0] == '-' || *end != '\0' || v < 1 || v > max)
        throw UsageError(option + ": '" + text + "' is not a whole number in 1.." + std::to_string(max));
    return v;
}

/// `v` when it is one of `allowed`.
inline std::string one_of(const std::string& option, const std::string& v, const std::vector<std::string>& allowed) {
    for (const std::string& a : allowed)
        if (v == a) return v;
    std::string list;
    for (const std::string& a : allowed) list += (list.empty() ? "" : "|") + a;
    throw UsageError(option + ": '" + v + "' is not one of " + list);
}

}  // namespace bench_cli

#endif  // SYLVA_BENCH_CLI_HPP

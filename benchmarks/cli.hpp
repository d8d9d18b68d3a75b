// benchmarks/cli.hpp -- what the benchmarks' CLI11 command lines (Debian libcli11-dev) share: one
// parse that prints --help on stdout (exit status 0) and bad usage as the message plus a hint on
// stderr (exit status 2), the usage error for checks made after parsing (reported the same way), image
// sizes WxH, and a number range that refuses NaN.
#ifndef SYLVA_BENCH_CLI_HPP
#define SYLVA_BENCH_CLI_HPP

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace bench_cli {

/// Bad usage found after parsing: reported like CLI11's own errors, exit status 2.
struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// Exit status of bad usage.
inline constexpr int kUsageStatus = 2;

/// Prints `message` as bad usage of `app`: the message, then where the help is.
inline int usage_error(const CLI::App& app, const std::string& message) {
    std::cerr << app.get_name() << ": " << message << "\nRun " << app.get_name()
              << " --help for the options.\n";
    return kUsageStatus;
}

/// Parses the command line into `app`'s bound variables. Empty when the program goes on; else the
/// exit status: 0 after --help (printed on stdout), 2 after bad usage (reported on stderr).
inline std::optional<int> parse(CLI::App& app, int argc, char** argv) {
    try {
        app.parse(argc, argv);
        return std::nullopt;
    } catch (const CLI::CallForHelp&) {
        std::cout << app.help();
        return 0;
    } catch (const CLI::CallForAllHelp&) {
        std::cout << app.help("", CLI::AppFormatMode::All);
        return 0;
    } catch (const CLI::ParseError& e) {
        return usage_error(app, e.what());
    }
}

/// "a|b|c".
inline std::string value_list(const std::set<std::string>& words) {
    std::string list;
    for (const std::string& w : words) list += (list.empty() ? "" : "|") + w;
    return list;
}

/// Why `text` is not an image size "WxH" with both in 1..max; empty when it is one (then in w, h).
inline std::string read_size(const std::string& text, std::uint32_t& w, std::uint32_t& h, std::uint32_t max) {
    std::size_t x = text.find('x');
    auto side = [&](const std::string& part, std::uint32_t& out) {
        if (part.empty() || part.find_first_not_of("0123456789") != std::string::npos || part.size() > 9) return false;
        unsigned long v = std::stoul(part);
        out = static_cast<std::uint32_t>(v);
        return v >= 1 && v <= max;
    };
    if (x == std::string::npos || !side(text.substr(0, x), w) || !side(text.substr(x + 1), h))
        return "'" + text + "' is not WxH with both in 1.." + std::to_string(max) + " (e.g. 320x240)";
    return std::string();
}

/// Adds `name` WxH (each side 1..max) writing `w` and `h`; its default shown is their values.
inline CLI::Option* add_size(CLI::App& app, const std::string& name, std::uint32_t& w, std::uint32_t& h,
                             const std::string& description, std::uint32_t max = 8192) {
    return app
        .add_option_function<std::string>(
            name, [&w, &h, max](const std::string& v) { read_size(v, w, h, max); }, description)
        ->type_name("WxH")
        ->default_str(std::to_string(w) + "x" + std::to_string(h))
        ->check(CLI::Validator(
            [max](std::string& v) {
                std::uint32_t a = 0, b = 0;
                return read_size(v, a, b, max);
            },
            ""));
}

/// A CLI11 check: a number in [lo, hi]; unlike CLI::Range it refuses NaN.
inline CLI::Validator number_in(double lo, double hi) {
    std::ostringstream range;
    range << "in [" << lo << ", " << hi << "]";
    return CLI::Validator(
        [lo, hi, text = range.str()](std::string& v) {
            double x = 0.0;
            if (!CLI::detail::lexical_cast(v, x) || !(x >= lo && x <= hi)) return "'" + v + "' is not a number " + text;
            return std::string();
        },
        "FLOAT " + range.str());
}

/// The value that follows option argv[i]; advances i past it. (Hand-written parsers not yet on CLI11.)
inline std::string value_of(int& i, int argc, char** argv) {
    if (i + 1 >= argc) throw UsageError(std::string(argv[i]) + " needs a value");
    return argv[++i];
}

/// A whole number in 1..max. (Hand-written parsers not yet on CLI11.)
inline std::size_t parse_count(const std::string& option, const std::string& text, std::size_t max) {
    char* end = nullptr;
    unsigned long v = std::strtoul(text.c_str(), &end, 10);
    if (text.empty() || text[0] == '-' || *end != '\0' || v < 1 || v > max)
        throw UsageError(option + ": '" + text + "' is not a whole number in 1.." + std::to_string(max));
    return v;
}

/// `v` when it is one of `allowed`. (Hand-written parsers not yet on CLI11.)
inline std::string one_of(const std::string& option, const std::string& v, const std::vector<std::string>& allowed) {
    for (const std::string& a : allowed)
        if (v == a) return v;
    std::string list;
    for (const std::string& a : allowed) list += (list.empty() ? "" : "|") + a;
    throw UsageError(option + ": '" + v + "' is not one of " + list);
}

}  // namespace bench_cli

#endif  // SYLVA_BENCH_CLI_HPP

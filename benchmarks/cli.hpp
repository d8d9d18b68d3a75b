// benchmarks/cli.hpp -- what the benchmarks' CLI11 command lines (Debian libcli11-dev) share: one
// parse that prints --help on stdout (exit status 0) and bad usage as the message plus a hint on
// stderr (exit status 2), options for image sizes WxH, a number range that refuses NaN and whole
// counts also written in e-notation (1e6). Used by sylva-bench, sylva-tables, -kd-bench, -iso-bench,
// -octree-bench, -volume-bench, -residency-bench, -store-bench, -moving-bench, -nanovdb-bench and
// -octree-elements-bench.
#ifndef SYLVA_BENCH_CLI_HPP
#define SYLVA_BENCH_CLI_HPP

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>

namespace bench_cli {

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

/// `x` as the help shows a limit: digits below 10^6, else e-notation without '+' and leading zeros
/// ("4e9").
inline std::string limit_label(double x) {
    std::ostringstream out;
    out << x;
    std::string s = out.str();
    std::size_t e = s.find("e+");
    if (e != std::string::npos) {
        std::size_t digits = s.find_first_not_of('0', e + 2);
        s = s.substr(0, e + 1) + (digits == std::string::npos ? "0" : s.substr(digits));
    }
    return s;
}

/// A CLI11 transform (add it with Option::transform): a whole number in [lo, hi] written as an
/// integer or in e-notation ("1e6", "2.5e5"), rewritten as its digits so that it converts to an
/// integer option (also each item of a delimited list).
inline CLI::Validator count_in(double lo, double hi) {
    std::string range = "in [" + limit_label(lo) + ", " + limit_label(hi) + "]";
    return CLI::Validator(
        [lo, hi, range](std::string& v) {
            double x = 0.0;
            if (!CLI::detail::lexical_cast(v, x) || !(x >= lo && x <= hi) || x != std::floor(x))
                return "'" + v + "' is not a whole number " + range;
            v = std::to_string(static_cast<unsigned long long>(x));
            return std::string();
        },
        "COUNT " + range);
}

/// A CLI11 check: a non-empty value (file names).
inline CLI::Validator non_empty() {
    return CLI::Validator([](std::string& v) { return v.empty() ? std::string("empty value") : std::string(); }, "");
}

}  // namespace bench_cli

#endif  // SYLVA_BENCH_CLI_HPP

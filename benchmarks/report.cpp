// benchmarks/report.cpp -- the records: JSON (through nlohmann-json) and the readable table.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "bench.hpp"

namespace bench {

void Report::add(std::string case_name, std::string impl, std::string metric, double value, std::string unit,
                 std::string peer, std::string config) {
    records_.push_back({std::move(case_name), std::move(impl), std::move(metric), value, std::move(unit),
                        std::move(peer), std::move(config)});
}

void Report::describe(const std::string& config, const std::string& text) {
    for (const auto& c : configs_)
        if (c.first == config) return;
    configs_.emplace_back(config, text);
}

const Record* Report::find(const std::string& case_name, const std::string& impl, const std::string& metric) const {
    for (const Record& r : records_)
        if (r.case_name == case_name && r.impl == impl && r.metric == metric) return &r;
    return nullptr;
}

bool Report::paired(const Record& peer) const {
    for (const Record& r : records_)
        if (r.impl != "embree" && r.peer == peer.case_name && r.metric == peer.metric) return true;
    return false;
}

namespace {

/// A value for the table: 4 significant digits, thousands as k/M/G for large ones.
std::string human(double v) {
    const char* suffix[] = {"", "k", "M", "G"};
    int s = 0;
    double a = std::fabs(v);
    while (a >= 10000.0 && s < 3) {
        a /= 1000.0;
        v /= 1000.0;
        ++s;
    }
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g%s", v, suffix[s]);
    return buf;
}

/// The throughput metrics of the summary table: steady-state and cold builds, steady-state and
/// first-pass traversals.
bool summary_metric(const std::string& m) {
    return m == "build_elements_per_s" || m == "build_cold_elements_per_s" || m == "rays_per_s" ||
           m == "rays_per_s_first_pass";
}

}  // namespace

void Report::write_json(const std::string& path) const {
    std::ofstream f(path);
    if (!f) throw std::runtime_error("sylva-bench: cannot open '" + path + "' for writing");
    f << "[\n";
    for (std::size_t i = 0; i < records_.size(); ++i) {
        const Record& r = records_[i];
        // NaN and infinities are not JSON (nlohmann would write null): a measurement that is
        // not finite is a bug to report, not a value.
        if (!std::isfinite(r.value))
            throw std::runtime_error("sylva-bench: " + r.case_name + " " + r.impl + " " + r.metric + " is not finite");
        nlohmann::ordered_json rec{{"case", r.case_name}, {"impl", r.impl}, {"metric", r.metric}, {"value", r.value},
                                   {"unit", r.unit}};
        if (!r.config.empty()) {
            std::string text = r.config;
            for (const auto& c : configs_)
                if (c.first == r.config) text = c.first + ": " + c.second;
            rec["config"] = text;
        }
        // One record a line; bytes that are not UTF-8 (a file name) become U+FFFD, never an error.
        f << "  " << rec.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace)
          << (i + 1 < records_.size() ? ",\n" : "\n");
    }
    f << "]\n";
    f.close();
    if (!f) throw std::runtime_error("sylva-bench: writing '" + path + "' failed");
}

void Report::print_table(bool summary) const {
    std::ostringstream out;
    auto row = [&](const std::string& c, const std::string& m, const std::string& a, const std::string& b,
                   const std::string& ratio, const std::string& unit) {
        out << std::left << std::setw(40) << c << std::setw(27) << m << std::right << std::setw(11) << a
            << std::setw(11) << b << std::setw(10) << ratio << "  " << unit << "\n";
    };
    if (summary) out << "\nSummary: throughput, sylva / embree (s/e > 1: sylva is faster)\n";
    row("case", "metric", "sylva", "embree", "s/e", "unit");
    out << std::string(105, '-') << "\n";
    for (const Record& r : records_) {
        const Record* e = nullptr;
        if (r.impl == "embree") {
            if (summary || paired(r)) continue;  // shown beside its sylva rows
        } else if (!r.peer.empty()) {
            e = find(r.peer, "embree", r.metric);
        }
        if (summary && (!e || !summary_metric(r.metric))) continue;
        std::string name = r.impl == "sylva" || r.impl == "embree" ? r.case_name : r.case_name + " [" + r.impl + "]";
        std::string ratio = e && e->value != 0.0 && r.metric != "runs" ? human(r.value / e->value) : "";
        if (r.impl == "embree")
            row(name, r.metric, "", human(r.value), "", r.unit);
        else
            row(name, r.metric, human(r.value), e ? human(e->value) : "", ratio, r.unit);
    }
    if (!configs_.empty()) out << "sylva configurations (the last part of each case name):\n";
    for (const auto& c : configs_) out << "  " << c.first << ": " << c.second << "\n";
    std::cout << out.str() << std::flush;
}

}  // namespace bench

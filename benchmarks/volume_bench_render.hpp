// benchmarks/volume_bench_render.hpp -- the renderers sylva-volume-bench times: the reference
// marcher and BIH-DVR on the host (all threads of a pool) and on the Vulkan device (lavapipe
// on a machine without a GPU), each the median of N renders.
#ifndef SYLVA_VOLUME_BENCH_RENDER_HPP
#define SYLVA_VOLUME_BENCH_RENDER_HPP

#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <sylva/core/error.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/render/volume.hpp>
#if SYLVA_VOLUME_BENCH_VULKAN
#include <sylva/vulkan/volume.hpp>
#endif

#include "volume_bench_report.hpp"

namespace volume_bench {

/// The last of N renders of one image, its time for every run and their median.
struct Timed {
    sylva::Frame frame;
    std::vector<double> ms;
    double median_ms = 0.0;
};

inline double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
}

/// Renders images 0..n-1 with `render(i, params)`, `runs` rounds of all of them in turn, so that
/// load from elsewhere on the machine hits every renderer alike. Before timing, one untimed 8x8
/// render of each keeps one-time costs of a first dispatch (pipeline compilation, first touch
/// of buffers) out of the figures.
template <class Render>
std::vector<Timed> interleaved(Render&& render, std::size_t n, const sylva::VolumeRenderParams& p, std::size_t runs) {
    sylva::VolumeRenderParams warm = p;
    warm.width = warm.height = 8;
    for (std::size_t i = 0; i < n; ++i) render(i, warm);
    std::vector<Timed> out(n);
    for (std::size_t r = 0; r < runs; ++r)
        for (std::size_t i = 0; i < n; ++i) {
            out[i].frame = render(i, p);
            out[i].ms.push_back(out[i].frame.ms);
        }
    for (Timed& t : out) t.median_ms = median(t.ms);
    return out;
}

/// Mean iterator steps per pixel; throws when a pixel reports a corrupt encoding.
inline double mean_steps(const sylva::Frame& f, const std::string& what) {
    double sum = 0.0;
    for (std::uint32_t s : f.steps) {
        if (s == 0xFFFFFFFFu) throw sylva::Error("sylva-volume-bench: " + what + ": the iterator found a corrupt encoding");
        sum += s;
    }
    return f.steps.empty() ? 0.0 : sum / double(f.steps.size());
}

/// The host pool and, when asked for, the Vulkan device.
class Renderers {
public:
    Renderers(const std::string& backend, sylva::ThreadPool& pool) : pool_(pool) {
        use_[Cpu] = backend == "cpu" || backend == "both";
        use_[Vulkan] = backend == "vulkan" || backend == "both";
#if SYLVA_VOLUME_BENCH_VULKAN
        if (use_[Vulkan]) ctx_.emplace(sylva::vk::Context::create());
#else
        if (use_[Vulkan])
            throw sylva::Error("--backend " + backend + ": this sylva-volume-bench was built without Vulkan");
#endif
    }

    [[nodiscard]] bool uses(int b) const { return use_[b]; }
    /// The backend whose images the quality figures come from: the host when it runs.
    [[nodiscard]] int first() const { return use_[Cpu] ? Cpu : Vulkan; }

    [[nodiscard]] std::string describe() const {
        std::string s;
        if (use_[Cpu]) s = "host, " + std::to_string(pool_.concurrency()) + " threads";
#if SYLVA_VOLUME_BENCH_VULKAN
        if (ctx_) s += (s.empty() ? "" : "; ") + std::string("Vulkan: ") + ctx_->describe();
#endif
        return s;
    }

    /// One race on backend `b`: image 0 is the reference marcher over `grid`, then BIH-DVR over
    /// each of `views` in each of `modes` (view-major), interleaved run by run (see interleaved).
    std::vector<Timed> race(const sylva::GridWords& grid, const std::vector<sylva::VoxelBihView>& views,
                            const std::vector<sylva::VolumeMode>& modes, const sylva::VolumeRenderParams& p, int b,
                            std::size_t runs) {
        auto bih_params = [&](std::size_t i, sylva::VolumeRenderParams q) {
            q.mode = modes[(i - 1) % modes.size()];
            return q;
        };
        std::size_t n = 1 + views.size() * modes.size();
        if (b == Cpu) {
            auto render = [&](std::size_t i, const sylva::VolumeRenderParams& q) {
                if (i == 0) return sylva::render_dvr_cpu(grid, q, pool_);
                return sylva::render_bih_dvr_cpu(views[(i - 1) / modes.size()], bih_params(i, q), pool_);
            };
            return interleaved(render, n, p, runs);
        }
#if SYLVA_VOLUME_BENCH_VULKAN
        sylva::vk::DeviceGrid dg(*ctx_, grid);
        std::vector<std::unique_ptr<sylva::vk::DeviceVoxelBih>> dv;
        for (const sylva::VoxelBihView& v : views) dv.push_back(std::make_unique<sylva::vk::DeviceVoxelBih>(*ctx_, v));
        auto render = [&](std::size_t i, const sylva::VolumeRenderParams& q) {
            if (i == 0) return sylva::vk::render_dvr_vulkan(*ctx_, dg, q);
            return sylva::vk::render_bih_dvr_vulkan(*ctx_, *dv[(i - 1) / modes.size()], bih_params(i, q));
        };
        return interleaved(render, n, p, runs);
#else
        throw sylva::Error("no Vulkan in this build");
#endif
    }

private:
    sylva::ThreadPool& pool_;
    bool use_[2] = {false, false};
#if SYLVA_VOLUME_BENCH_VULKAN
    std::optional<sylva::vk::Context> ctx_;
#endif
};

}  // namespace volume_bench

#endif  // SYLVA_VOLUME_BENCH_RENDER_HPP

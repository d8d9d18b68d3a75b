// sylva-render, moving particles: --animate N with --index bih|kd|octree and --update
// refit|rebuild, on --backend cpu or vulkan, in --order exact (the generic element kernel) or leaf
// (each index's own integrator). Header only: main.cpp, the one includer, dispatches here.
//
// Motion (deterministic, the same in every run): particle i oscillates along its own unit
// direction d_i (from the golden angle) by A sin(2 pi f / 16 + i), A = 2 % of the particles'
// box's largest extent; frame f = 1..N. Per frame the index follows (refit or rebuild), is
// encoded, the records are packed and the frame is rendered; the last frame is written. The BIH
// is the query layout (4 particles a leaf, untrimmed, RangePayload records) whatever --payload
// says: a refit keeps leaves, so leaves trimmed to one particle would not stay trimmed.
//
// On Vulkan one context and one kernel serve all N frames (AnimationRenderer): per frame only the
// encoding and the records go to the device, into buffers made anew on that context (the device
// classes have no update method); vk::ElementKernel and vk::ParticleKernel keep their pipelines
// per specialization constants (a rebuilt BIH of another depth adds one). --order leaf --index
// octree makes its vk::DeviceElementOctree, and with it the octree kernel's pipeline, every frame
// (the class owns its kernel). --order leaf --index kd has no Vulkan kernel (refused by parse()).
#ifndef SYLVA_RENDER_ANIMATION_SCENE_HPP
#define SYLVA_RENDER_ANIMATION_SCENE_HPP

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <numeric>
#include <span>
#include <string>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/refit.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/kdtree/elements.hpp>
#include <sylva/kdtree/elements_encode.hpp>
#include <sylva/octree/elements.hpp>
#include <sylva/octree/elements_encode.hpp>
#include <sylva/octree/elements_refit.hpp>
#include <sylva/render/camera.hpp>
#include <sylva/render/image.hpp>
#include <sylva/render/kd_particles.hpp>
#include <sylva/render/octree_particles.hpp>
#include <sylva/render/particles.hpp>
#ifdef SYLVA_RENDER_VULKAN
#include <sylva/vulkan/bih.hpp>
#include <sylva/vulkan/elements.hpp>
#include <sylva/vulkan/octree_particles.hpp>
#endif

#include "exact_particles_scene.hpp"
#include "kd_particles_scene.hpp"
#include "options.hpp"
#include "stats.hpp"

namespace sylva_render {

/// Frame `frame` of the deterministic motion of `base` into `out`.
inline void move_particles(std::span<const sylva::Sphere> base, std::uint32_t frame, float amplitude,
                           std::vector<sylva::Sphere>& out, sylva::ThreadPool& pool) {
    using namespace sylva;
    out.resize(base.size());
    pool.parallel_for(0, base.size(), 16384, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i) {
            float a = float(i) * 2.39996323f, z = 1.0f - 2.0f * float(i % 1024) / 1023.0f, r = std::sqrt(1.0f - z * z);
            vec3 d(r * std::cos(a), r * std::sin(a), z);
            out[i] = base[i];
            out[i].center += amplitude * std::sin(6.2831853f * float(frame) / 16.0f + float(i)) * d;
        }
    });
}

/// The index that follows the motion (--index bih|kd|octree), refit or rebuilt per frame and
/// encoded with its particle records.
class MovingIndex {
public:
    /// Builds --index over `spheres`; build_ms() is the time taken.
    MovingIndex(const Options& o, std::span<const sylva::Sphere> spheres, sylva::ThreadPool& pool)
        : index_(o.index), refit_(o.update == "refit"), identity_(spheres.size()) {
        std::iota(identity_.begin(), identity_.end(), 0u);
        bcfg_.max_leaf_elements = 4;
        bcfg_.trim_leaves = false;
        bcfg_.empty_children =
            o.empty_children == "infinite" ? sylva::bih::EmptyChildren::Infinite : sylva::bih::EmptyChildren::TrimBoth;
        // The octree's lattice grown by 5 % of the box's longest side on every side: room for the
        // motion (at most 2 %), so every refit stays a refit instead of falling back to a rebuild.
        ocfg_.refit_margin = 0.05f;
        auto t0 = std::chrono::steady_clock::now();
        if (index_ == "bih") bt_ = sylva::bih::build(spheres, bcfg_, pool);
        else if (index_ == "kd") kt_ = sylva::kdtree::build_elements(spheres, kcfg_, pool);
        else ot_ = sylva::octree::build_elements(spheres, ocfg_, pool);
        build_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }

    [[nodiscard]] double build_ms() const { return build_ms_; }

    /// Follows the moved `spheres` (refit or rebuild); false when an octree refit fell back to a
    /// rebuild (an element left the lattice).
    bool update(std::span<const sylva::Sphere> spheres, sylva::ThreadPool& pool) {
        using namespace sylva;
        if (index_ == "bih") {
            if (refit_) bih::refit(bt_, spheres, pool);
            else bih::rebuild(bt_, spheres, bcfg_, pool);
        } else if (index_ == "kd") {
            if (refit_) kdtree::refit_elements(kt_, spheres, kcfg_, pool);
            else kdtree::rebuild_elements(kt_, spheres, kcfg_, pool);
        } else if (refit_) {
            return octree::update_elements(ot_, spheres, ocfg_, pool);
        } else {
            octree::rebuild_elements(ot_, spheres, ocfg_, pool);
        }
        return true;
    }

    /// The encoding into `words` and the particle records into `records` (the BIH's in its tree
    /// order, the kd-tree's and octree's in the spheres' order).
    void encode(std::span<const sylva::Sphere> spheres, std::vector<std::uint32_t>& words,
                std::vector<std::uint32_t>& records) const {
        using namespace sylva;
        if (index_ == "bih") {
            words = bih::encode(bt_, spheres, bih::RangePayload{});
            records = pack_particles(spheres, std::span<const std::uint32_t>(bt_.order));
        } else {
            words = index_ == "kd" ? kdtree::encode_elements(kt_) : octree::encode_elements(ot_);
            records = pack_particles(spheres, std::span<const std::uint32_t>(identity_));
        }
    }

private:
    std::string index_;
    bool refit_;
    std::vector<std::uint32_t> identity_;
    sylva::bih::Config bcfg_;
    sylva::kdtree::ElementConfig kcfg_;
    sylva::octree::ElementConfig ocfg_;
    sylva::bih::Tree bt_;
    sylva::kdtree::ElementTree kt_;
    sylva::octree::ElementTree ot_;
    double build_ms_ = 0;
};

/// Renders the frames of --animate on --backend: the host's integrators, or one Vulkan context
/// and one kernel made here for every frame, to which each frame uploads its encoding and records.
class AnimationRenderer {
public:
    AnimationRenderer(const Options& o, sylva::ThreadPool& pool) : o_(o), pool_(pool) {
        if (o.backend == "cpu") {
            device_ = "host, " + std::to_string(pool.concurrency()) + " threads";
            return;
        }
#ifdef SYLVA_RENDER_VULKAN
        ctx_ = std::make_unique<sylva::vk::Context>(sylva::vk::Context::create());
        device_ = ctx_->describe();
        if (o.order == "exact") {
            elements_ = std::make_unique<sylva::vk::ElementKernel>(*ctx_, exact_kernel_spirv(o));
        } else if (o.index == "bih") {
            particles_ = std::make_unique<sylva::vk::ParticleKernel>(*ctx_);
        }
#else
        throw sylva::Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
    }

    /// The host and its threads, or the Vulkan device (vk::Context::describe).
    [[nodiscard]] const std::string& device() const { return device_; }
    /// Whether frames go to a Vulkan device (and upload_ms() means something).
    [[nodiscard]] bool on_device() const { return o_.backend != "cpu"; }
    /// The last frame's upload (making the device buffers of its encoding and records), ms.
    [[nodiscard]] double upload_ms() const { return upload_ms_; }

    /// One frame of `words` (the encoding of --index) and `records` (its particle records).
    sylva::Frame render(std::span<const std::uint32_t> words, std::span<const std::uint32_t> records,
                        const sylva::CameraFrame& cam) {
        using namespace sylva;
        ParticleRenderConfig rc = particle_config(o_);
        if (!on_device()) {
            if (o_.order == "exact") return render_exact_particles(o_, words, records, cam, pool_, device_);
            if (o_.index == "bih") return render_particles_cpu(words, records, cam, o_.width, o_.height, pool_, rc);
            if (o_.index == "kd") return render_particles_kd_cpu(words, records, cam, o_.width, o_.height, pool_, rc);
            return render_particles_octree_cpu(words, records, cam, o_.width, o_.height, pool_, rc);
        }
#ifdef SYLVA_RENDER_VULKAN
        if (o_.order == "exact") return render_exact_vulkan(words, records, cam, rc);
        auto t0 = std::chrono::steady_clock::now();
        if (o_.index == "bih") {
            vk::DeviceBih bih(*ctx_, words);
            vk::Buffer recs(*ctx_, records.size() * 4);
            if (!records.empty()) recs.upload(records);
            upload_ms_ = ms_since(t0);
            return particles_->render(bih, recs, cam, o_.width, o_.height, rc);
        }
        vk::DeviceElementOctree oct(*ctx_, words, records);  // --order leaf --index octree (kd: refused)
        upload_ms_ = ms_since(t0);
        return vk::render_particles_octree_vulkan(*ctx_, oct, cam, o_.width, o_.height, rc);
#else
        throw Error("--backend vulkan: this sylva-render was built without Vulkan (SYLVA_WITH_VULKAN=OFF)");
#endif
    }

private:
    static double ms_since(std::chrono::steady_clock::time_point t0) {
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }
#ifdef SYLVA_RENDER_VULKAN
    /// --order exact on the device: the generic element kernel over a DeviceBih (--index bih) or a
    /// DeviceElementIndex (kd, octree) and the records.
    sylva::Frame render_exact_vulkan(std::span<const std::uint32_t> words, std::span<const std::uint32_t> records,
                                     const sylva::CameraFrame& cam, const sylva::ParticleRenderConfig& rc) {
        using namespace sylva;
        auto t0 = std::chrono::steady_clock::now();
        vk::DeviceRecords recs(*ctx_, records, element_words<Sphere>());
        if (o_.index == "bih") {
            vk::DeviceBih bih(*ctx_, words);
            upload_ms_ = ms_since(t0);
            return elements_->render(bih, recs, cam, o_.width, o_.height, rc);
        }
        vk::DeviceElementIndex index(*ctx_, words);
        upload_ms_ = ms_since(t0);
        return elements_->render(index, recs, cam, o_.width, o_.height, rc);
    }

#endif
    const Options& o_;
    sylva::ThreadPool& pool_;
    std::string device_;
    double upload_ms_ = 0;
#ifdef SYLVA_RENDER_VULKAN
    std::unique_ptr<sylva::vk::Context> ctx_;  // a stable address: the kernels keep a pointer to it
    std::unique_ptr<sylva::vk::ElementKernel> elements_;  // destroyed before ctx_
    std::unique_ptr<sylva::vk::ParticleKernel> particles_;
#endif
};

/// Per-frame times of an animation and their medians.
struct AnimationTimes {
    std::vector<double> update, encode, upload, render;

    static double median(std::vector<double> v) {
        std::sort(v.begin(), v.end());
        return v.empty() ? 0.0 : v[v.size() / 2];
    }
    /// One frame's line: update, encode, (on a device) upload and render, ms.
    void print_frame(std::ostream& out, std::uint32_t frame, const std::string& update_kind, bool device) const {
        Fixed2 fixed(out);
        out << "frame " << frame << ": " << update_kind << " " << update.back() << " ms, encode " << encode.back() << " ms, ";
        if (device) out << "upload " << upload.back() << " ms, ";
        out << "render " << render.back() << " ms\n";
    }
    /// The medians over all frames.
    void print_summary(std::ostream& out, const Options& o, bool device, double build_ms, std::size_t fallbacks) const {
        Fixed2 fixed(out);
        out << "animation: " << o.animate << " frames, --index " << o.index << " --update " << o.update << " --backend "
            << o.backend << ": median update " << median(update) << " ms, encode " << median(encode) << " ms, ";
        if (device) out << "upload " << median(upload) << " ms, ";
        out << "render " << median(render) << " ms (first build " << build_ms << " ms)";
        if (fallbacks) out << "; " << fallbacks << " octree refits fell back to a rebuild (particles left the lattice)";
        out << "\n";
    }

private:
    /// Two decimals on `out` while it lives; the stream's format after.
    struct Fixed2 {
        std::ostream& out;
        std::ios::fmtflags flags;
        std::streamsize precision;
        explicit Fixed2(std::ostream& o) : out(o), flags(o.flags()), precision(o.precision()) {
            out << std::fixed << std::setprecision(2);
        }
        ~Fixed2() {
            out.flags(flags);
            out.precision(precision);
        }
        Fixed2(const Fixed2&) = delete;
        Fixed2& operator=(const Fixed2&) = delete;
    };
};

/// --animate N: moves the particles for N frames, refitting or rebuilding the index per frame;
/// prints per-frame update, encode, (Vulkan) upload and render times and their medians; writes
/// the last frame. The Vulkan context and kernel are made once, before the first frame.
inline int run_particle_animation(const Options& o, std::span<const sylva::Sphere> base, sylva::ThreadPool& pool,
                                  Stats& s) {
    using namespace sylva;
    Aabb box;
    for (const Sphere& p : base) box.extend(bounds_of(p));
    vec3 ext = box.empty() ? vec3(1.0f) : box.extent();
    float amplitude = 0.02f * std::max({ext.x, ext.y, ext.z});
    std::vector<Sphere> now(base.begin(), base.end());
    CameraFrame cam = particle_camera(o, base);
    AnimationRenderer renderer(o, pool);
    MovingIndex index(o, std::span<const Sphere>(now), pool);
    s.build_ms = index.build_ms();
    AnimationTimes times;
    std::size_t fallbacks = 0;
    Frame f;
    std::vector<std::uint32_t> words, records;
    for (std::uint32_t frame = 1; frame <= o.animate; ++frame) {
        move_particles(base, frame, amplitude, now, pool);
        std::span<const Sphere> cur(now);
        auto t0 = std::chrono::steady_clock::now();
        fallbacks += index.update(cur, pool) ? 0u : 1u;
        times.update.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        t0 = std::chrono::steady_clock::now();
        index.encode(cur, words, records);
        times.encode.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        f = renderer.render(words, records, cam);
        times.upload.push_back(renderer.upload_ms());
        times.render.push_back(f.ms);
        s.bytes = words.size() * 4 + records.size() * 4;
        if (!o.quiet) times.print_frame(std::cout, frame, o.update, renderer.on_device());
    }
    if (!o.quiet) times.print_summary(std::cout, o, renderer.on_device(), s.build_ms, fallbacks);
    s.index = o.index;
    s.elements = base.size();
    s.encode_ms = AnimationTimes::median(times.encode);
    s.device = renderer.device();
    return finish_particle_frame(o, f, s);
}

}  // namespace sylva_render

#endif

// sylva/store/slices.hpp -- volumes read or generated one z slice at a time, for the streamed
// store builder (sylva/store/stream_build.hpp): a volume of any size is never whole in memory.
//
// Each source yields the same normalised densities as the in-core path gives for the same
// input, bit for bit: raw files through volume::normalize with the range volume::choose_range
// picks (read_raw + normalize), Marschner-Lobb through the formula of volume::marschner_lobb,
// resampling through the reconstruction of volume::resample_trilinear.
#ifndef SYLVA_STORE_SLICES_HPP
#define SYLVA_STORE_SLICES_HPP

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "sylva/core/error.hpp"
#include "sylva/core/executor.hpp"
#include "sylva/volume/grid.hpp"
#include "sylva/volume/occupancy.hpp"
#include "sylva/volume/procedural.hpp"
#include "sylva/volume/read_raw.hpp"
#include "sylva/volume/resample.hpp"
#include "sylva/volume/value_range.hpp"

namespace sylva::store {

/// A volume delivered slice by slice. `read(z, out)` fills `out` (dims().x * dims().y floats,
/// x fastest) with the normalised densities of slice z; callers ask for z = 0, 1, 2, ... in order.
class SliceSource {
public:
    virtual ~SliceSource() = default;
    [[nodiscard]] virtual volume::Dims dims() const = 0;
    [[nodiscard]] virtual vec3 spacing() const = 0;
    virtual void read(std::uint32_t z, std::span<float> out) = 0;
    /// read() with rows computed on `pool` (sources that compute their voxels override it).
    virtual void read(std::uint32_t z, std::span<float> out, ThreadPool& pool) {
        (void)pool;
        read(z, out);
    }
    /// Type of the voxels as stored at the source ("uint8", "uint16", "float32").
    [[nodiscard]] virtual std::string voxel_type() const { return "float32"; }
    /// Raw values mapped to density 0 and 1, and where that range came from.
    [[nodiscard]] virtual float range_lo() const { return 0.0f; }
    [[nodiscard]] virtual float range_hi() const { return 1.0f; }
    [[nodiscard]] virtual std::string range_source() const { return "procedural densities"; }
    /// Bytes the source holds in memory besides the slice it fills.
    [[nodiscard]] virtual std::uint64_t memory_bytes() const { return 0; }
    /// Bytes of source voxels per slice (for throughput figures).
    [[nodiscard]] virtual std::uint64_t slice_source_bytes() const { return std::uint64_t(dims().x) * dims().y * 4u; }
};

/// An in-memory density grid (NRRD files, tests).
class GridSlices final : public SliceSource {
public:
    explicit GridSlices(volume::DensityGrid g, std::string type = "float32", float lo = 0.0f, float hi = 1.0f,
                        std::string source = "procedural densities")
        : g_(std::move(g)), type_(std::move(type)), lo_(lo), hi_(hi), source_(std::move(source)) {}
    [[nodiscard]] volume::Dims dims() const override { return g_.dims; }
    [[nodiscard]] vec3 spacing() const override { return g_.spacing; }
    void read(std::uint32_t z, std::span<float> out) override {
        const std::size_t n = std::size_t(g_.dims.x) * g_.dims.y;
        std::copy_n(g_.values.begin() + std::ptrdiff_t(n * z), n, out.begin());
    }
    [[nodiscard]] std::string voxel_type() const override { return type_; }
    [[nodiscard]] float range_lo() const override { return lo_; }
    [[nodiscard]] float range_hi() const override { return hi_; }
    [[nodiscard]] std::string range_source() const override { return source_; }
    [[nodiscard]] std::uint64_t memory_bytes() const override { return g_.values.size() * 4u; }

private:
    volume::DensityGrid g_;
    std::string type_;
    float lo_, hi_;
    std::string source_;
};

/// The Marschner-Lobb signal on `dims` voxels, exactly as volume::marschner_lobb samples it.
class MarschnerLobbSlices final : public SliceSource {
public:
    explicit MarschnerLobbSlices(volume::Dims dims, const volume::MarschnerLobbConfig& cfg = {}) : dims_(dims), cfg_(cfg) {
        (void)volume::voxel_count(dims, sizeof(float));  // throws for zero or overflowing dims
        if (!all_finite(cfg.spacing) || !(cfg.spacing.x > 0.0f) || !(cfg.spacing.y > 0.0f) || !(cfg.spacing.z > 0.0f))
            throw Error("marschner_lobb: spacing must be finite and positive");
    }
    [[nodiscard]] volume::Dims dims() const override { return dims_; }
    [[nodiscard]] vec3 spacing() const override { return cfg_.spacing; }
    void read(std::uint32_t z, std::span<float> out) override { rows(z, 0, dims_.y, out); }
    void read(std::uint32_t z, std::span<float> out, ThreadPool& pool) override {
        pool.parallel_for(0, dims_.y, 4, [&](std::size_t y0, std::size_t y1) { rows(z, y0, y1, out); });
    }

private:
    void rows(std::uint32_t z, std::size_t y0, std::size_t y1, std::span<float> out) const {
        const vec3 extent = vec3(dims_) * cfg_.spacing;  // as in volume::marschner_lobb
        std::size_t i = y0 * dims_.x;
        for (std::uint32_t y = std::uint32_t(y0); y < y1; ++y)
            for (std::uint32_t x = 0; x < dims_.x; ++x) {
                vec3 c = (vec3(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)) + 0.5f) * cfg_.spacing;
                out[i++] = std::clamp(volume::marschner_lobb_at(2.0f * c / extent - 1.0f, cfg_.f_m, cfg_.alpha), 0.0f, 1.0f);
            }
    }

    volume::Dims dims_;
    volume::MarschnerLobbConfig cfg_;
};

/// A NAME_XxYxZ_TYPE.raw file read slice by slice. The constructor checks the file's size and,
/// when the range needs the data (auto, float32 type), reads it once for its min and max (and
/// rejects NaN/infinite voxels, naming the first); densities are then exactly read_raw +
/// volume::normalize's.
class RawFileSlices final : public SliceSource {
public:
    RawFileSlices(const std::filesystem::path& path, const volume::RawInfo& info, const volume::ValueRange& range = {})
        : path_(path), info_(info), what_("raw volume " + path.string()) {
        const std::size_t width = volume::scalar_bytes(info.type);
        const std::size_t n = volume::detail::checked_voxel_count(info.dims, width, what_);
        volume::detail::check_spacing(info.spacing, what_);
        std::error_code ec;
        if (!std::filesystem::is_regular_file(path, ec)) throw Error(what_ + ": no such file");
        const std::uintmax_t actual = std::filesystem::file_size(path, ec);
        const std::uintmax_t expected = std::uintmax_t{n} * width;
        if (ec || actual != expected)
            throw Error(what_ + ": " + std::to_string(actual) + " bytes, but " + volume::detail::dims_text(info.dims) +
                        " " + volume::scalar_name(info.type) + " voxels need " + std::to_string(expected) + " bytes (" +
                        (actual < expected ? "truncated" : "too big") + ")");
        fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd_ < 0) throw Error(what_ + ": cannot open: " + std::strerror(errno));
        choose(range);
    }
    RawFileSlices(const RawFileSlices&) = delete;
    RawFileSlices& operator=(const RawFileSlices&) = delete;
    ~RawFileSlices() override {
        if (fd_ >= 0) ::close(fd_);
    }
    [[nodiscard]] volume::Dims dims() const override { return info_.dims; }
    [[nodiscard]] vec3 spacing() const override { return info_.spacing; }
    void read(std::uint32_t z, std::span<float> out) override {
        if (slab_.bytes.empty()) slab_ = slab_volume();
        read_bytes(std::uint64_t(z) * slab_.bytes.size(), slab_.bytes);
        check_finite(slab_, std::uint64_t(z) * slab_.voxels());
        // volume::normalize's arithmetic, without its per-call allocation: clamp((x - lo) / span,
        // 0, 1), or 0 for an empty span (the classifiers' volume::detail::normalised).
        const float lo = slab_.range_lo, span = slab_.range_hi - slab_.range_lo;
        for (std::size_t i = 0; i < out.size(); ++i) out[i] = volume::detail::normalised(slab_.value(i), lo, span);
    }
    [[nodiscard]] std::string voxel_type() const override { return volume::scalar_name(info_.type); }
    [[nodiscard]] float range_lo() const override { return lo_; }
    [[nodiscard]] float range_hi() const override { return hi_; }
    [[nodiscard]] std::string range_source() const override { return volume::range_source_name(source_); }
    [[nodiscard]] std::uint64_t memory_bytes() const override { return slice_source_bytes() * 2u; }
    [[nodiscard]] std::uint64_t slice_source_bytes() const override {
        return std::uint64_t(info_.dims.x) * info_.dims.y * volume::scalar_bytes(info_.type);
    }

private:
    /// An empty one-slice volume with this file's type and chosen range.
    [[nodiscard]] volume::Volume slab_volume() const {
        volume::Volume v;
        v.type = info_.type;
        v.dims = volume::Dims(info_.dims.x, info_.dims.y, 1u);
        v.spacing = info_.spacing;
        v.bytes.resize(slice_source_bytes());
        v.range_lo = lo_;
        v.range_hi = hi_;
        v.range_source = source_;
        return v;
    }
    void read_bytes(std::uint64_t offset, std::vector<std::byte>& bytes) const {
        std::size_t done = 0;
        while (done < bytes.size()) {
            ssize_t r = ::pread(fd_, bytes.data() + done, bytes.size() - done, off_t(offset + done));
            if (r < 0 && errno == EINTR) continue;
            if (r <= 0) throw Error(what_ + ": cannot read at byte " + std::to_string(offset + done));
            done += std::size_t(r);
        }
    }
    void check_finite(const volume::Volume& slab, std::uint64_t first) const {
        if (info_.type != volume::ScalarType::F32) return;
        for (std::size_t i = 0; i < slab.voxels(); ++i)
            if (!std::isfinite(slab.value(i)))
                throw Error(what_ + ": float32 voxel " + std::to_string(first + i) + " is " +
                            (std::isnan(slab.value(i)) ? "NaN" : "infinite"));
    }
    /// The range choose_range picks for the whole file: it reads the data only through its min
    /// and max, so a two-voxel volume holding them gives the same answer.
    void choose(const volume::ValueRange& range) {
        volume::Volume probe = slab_volume();
        probe.dims = volume::Dims(2u, 1u, 1u);
        probe.bytes.assign(2 * volume::scalar_bytes(info_.type), std::byte{0});
        bool needs_data = range.mode == volume::ValueRange::Mode::Auto ||
                          (range.mode == volume::ValueRange::Mode::Type && info_.type == volume::ScalarType::F32);
        if (needs_data) {
            std::size_t lo_at = 0, hi_at = 0;
            scan_min_max(lo_at, hi_at);
            volume::Volume slab = slab_volume();
            std::size_t w = volume::scalar_bytes(info_.type);
            std::vector<std::byte> one(w);
            read_bytes(lo_at * w, one);
            std::memcpy(probe.bytes.data(), one.data(), w);
            read_bytes(hi_at * w, one);
            std::memcpy(probe.bytes.data() + w, one.data(), w);
        }
        auto [r, src] = volume::choose_range(probe, range, what_);
        lo_ = r.first;
        hi_ = r.second;
        source_ = src;
    }
    /// Indices of a smallest and a largest voxel (one pass, slice by slice; NaN/inf rejected).
    void scan_min_max(std::size_t& lo_at, std::size_t& hi_at) const {
        volume::Volume slab = slab_volume();
        float lo = std::numeric_limits<float>::infinity(), hi = -lo;
        for (std::uint32_t z = 0; z < info_.dims.z; ++z) {
            read_bytes(std::uint64_t(z) * slab.bytes.size(), slab.bytes);
            std::uint64_t first = std::uint64_t(z) * slab.voxels();
            check_finite(slab, first);
            for (std::size_t i = 0; i < slab.voxels(); ++i) {
                float v = slab.value(i);  // exact for uint8, uint16 and float32
                if (v < lo) lo = v, lo_at = first + i;
                if (v > hi) hi = v, hi_at = first + i;
            }
        }
    }

    std::filesystem::path path_;
    volume::RawInfo info_;
    std::string what_;
    volume::Volume slab_;  ///< the slice being read (bytes reused)
    int fd_ = -1;
    float lo_ = 0.0f, hi_ = 1.0f;
    volume::RangeSource source_ = volume::RangeSource::Data;
};

/// `source` supersampled (or subsampled) by `factor` with volume::resample_trilinear's rule, one
/// output slice at a time: the source grid is held, the resampled volume never is.
class ResampledSlices final : public SliceSource {
public:
    ResampledSlices(std::unique_ptr<SliceSource> source, float factor) : inner_(std::move(source)) {
        volume::Dims d = inner_->dims();
        grid_.dims = d;
        grid_.spacing = inner_->spacing();
        grid_.values.resize(volume::voxel_count(d, sizeof(float)));
        const std::size_t n = std::size_t(d.x) * d.y;
        for (std::uint32_t z = 0; z < d.z; ++z) inner_->read(z, std::span<float>(grid_.values.data() + n * z, n));
        dims_ = volume::resampled_dims(d, factor);
        spacing_ = vec3(grid_.dims) * grid_.spacing / vec3(dims_);
        for (int a = 0; a < 3; ++a)
            for (std::uint32_t j = 0; j < dims_[a]; ++j)
                axes_[a].push_back(volume::detail::resample::axis_weights((static_cast<float>(j) + 0.5f) * spacing_[a],
                                                                          grid_.spacing[a], grid_.dims[a]));
    }
    [[nodiscard]] volume::Dims dims() const override { return dims_; }
    [[nodiscard]] vec3 spacing() const override { return spacing_; }
    void read(std::uint32_t z, std::span<float> out) override { rows(z, 0, dims_.y, out); }
    void read(std::uint32_t z, std::span<float> out, ThreadPool& pool) override {
        pool.parallel_for(0, dims_.y, 4, [&](std::size_t y0, std::size_t y1) { rows(z, y0, y1, out); });
    }
    [[nodiscard]] std::string voxel_type() const override { return inner_->voxel_type(); }
    [[nodiscard]] float range_lo() const override { return inner_->range_lo(); }
    [[nodiscard]] float range_hi() const override { return inner_->range_hi(); }
    [[nodiscard]] std::string range_source() const override { return inner_->range_source(); }
    [[nodiscard]] std::uint64_t memory_bytes() const override { return grid_.values.size() * 4u + inner_->memory_bytes(); }

private:
    void rows(std::uint32_t z, std::size_t y0, std::size_t y1, std::span<float> out) const {
        std::size_t i = y0 * dims_.x;
        for (std::uint32_t y = std::uint32_t(y0); y < y1; ++y)
            for (std::uint32_t x = 0; x < dims_.x; ++x)
                out[i++] = volume::detail::resample::trilinear(grid_, axes_[0][x], axes_[1][y], axes_[2][z]);
    }

    std::unique_ptr<SliceSource> inner_;
    volume::DensityGrid grid_;
    volume::Dims dims_{0};
    vec3 spacing_{1.0f};
    std::vector<volume::detail::resample::AxisWeights> axes_[3];
};

}  // namespace sylva::store

#endif  // SYLVA_STORE_SLICES_HPP

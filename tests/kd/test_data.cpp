// Real volumes from ../shared/data: occupancy counts that Kinkelin's tables fix independently,
// and trees on the engine whose builders must agree and cull only empty space.
#include <catch2/catch.hpp>

#include <sylva/core/executor.hpp>
#include <sylva/kdtree/build.hpp>
#include <sylva/kdtree/build_binned.hpp>
#include <sylva/kdtree/build_parallel.hpp>
#include <sylva/kdtree/encode.hpp>
#include <sylva/kdtree/local_boxes.hpp>
#include <sylva/kdtree/validate.hpp>
#include <sylva/volume/classify.hpp>
#include <sylva/volume/partial_svt.hpp>
#include <sylva/volume/read_raw.hpp>
#include <sylva/volume/svt.hpp>

#include "reference.hpp"

using namespace sylva;
using namespace sylva::kdtest;

namespace {

volume::Volume load(const std::string& path) { return volume::read_raw(path, volume::parse_raw_name(path)); }

/// Every occupied voxel lies in a leaf, leaves are tight, and (validate) do not overlap.
void check_leaves(const kdtree::Tree& t, const volume::SummedVolumeTable<std::uint32_t>& svt) {
    std::uint64_t held = 0;
    for (std::size_t i = 0; i < t.leaves.size(); ++i) {
        held += svt.count(t.leaf_box(i));
        REQUIRE(svt.tight_box(t.leaf_box(i)) == t.leaf_box(i));
    }
    CHECK(held == svt.total());
    kdtree::validate(kdtree::encode(t));
}

}  // namespace

TEST_CASE("data: occupied voxels at density >= 0.1 match Kinkelin's element counts", "[data]") {
    ThreadPool pool(2);
    struct Case { const char* file; std::uint64_t count; };
    for (Case c : {Case{"aneurism_256x256x256_uint8.raw", 113453}, Case{"engine_256x256x128_uint8.raw", 1352439},
                   Case{"lobster_301x324x56_uint8.raw", 341256}}) {
        std::string path = data_file(c.file);
        if (path.empty()) continue;
        INFO(path);
        volume::Volume v = load(path);
        auto src = volume::classified(v, volume::DensityThreshold{0.1f});
        CHECK(volume::count_occupied(src, pool) == c.count);
        CHECK(volume::SummedVolumeTable<std::uint32_t>(src).total() == c.count);
        CHECK(volume::PartialSvt<32>(src, pool).total() == c.count);
        CHECK(kdtree::local_boxes(src, pool).occupied == c.count);
    }
}

TEST_CASE("data: engine trees from all builders cull only empty space, parallel equals serial", "[data]") {
    std::string path = data_file("engine_256x256x128_uint8.raw");
    if (path.empty()) return;
    ThreadPool pool(2);
    volume::Volume v = load(path);
    auto src = volume::classified(v, volume::DensityThreshold{0.1f});
    volume::SummedVolumeTable<std::uint32_t> svt(src);
    volume::PartialSvt<32> psvt(src, pool);
    kdtree::LocalBoxes boxes = kdtree::local_boxes(src, pool);
    for (kdtree::Config cfg : {kdtree::Config::shallow(), kdtree::Config::deep()}) {
        kdtree::Tree serial = kdtree::build(svt, cfg);
        kdtree::Tree parallel = kdtree::build(psvt, cfg, pool);
        kdtree::Tree binned = kdtree::build(boxes, cfg, pool);
        INFO("min volume " << cfg.min_volume_voxels << ": serial " << serial.stats.percent_culled() << " % culled, "
                           << serial.leaves.size() << " leaves; binned " << binned.stats.percent_culled() << " %, "
                           << binned.leaves.size() << " leaves");
        REQUIRE(parallel.nodes == serial.nodes);
        check_leaves(serial, svt);
        check_leaves(binned, svt);
        CHECK(serial.stats.percent_culled() > 30.0);
        CHECK(binned.stats.percent_culled() >= serial.stats.percent_culled() - 15.0);
        CHECK(kdtree::build(boxes, cfg, pool).nodes == kdtree::build(svt, cfg.binned()).nodes);
    }
}

// 01_minimal: a BIH over your own element type, and one ray's leaves front to back.
#include <cstdio>
#include <vector>

#include <sylva/bih/build.hpp>
#include <sylva/bih/encode.hpp>
#include <sylva/bih/query.hpp>

struct Crate {  // any type with bounds() is an element
    sylva::vec3 lo, hi;
    sylva::Aabb bounds() const { return {lo, hi}; }
};

int main() {
    std::vector<Crate> crates;
    for (int i = 0; i < 8; ++i) crates.push_back({{float(i), 0.0f, 0.0f}, {i + 0.5f, 1.0f, 1.0f}});
    std::span<const Crate> elems(crates);

    sylva::bih::Tree tree = sylva::bih::build(elems);                               // build
    auto words = sylva::bih::encode(tree, elems, sylva::bih::RangePayload{});       // encode
    sylva::bih::LeafIterator leaves(words, {{-1.0f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}});  // iterate
    int visited = 0;
    while (auto leaf = leaves.next()) {
        auto [first, count] = sylva::bih::decode_range(leaf->payload);
        std::printf("crate %u: t in [%.2f, %.2f]\n", tree.order[first], leaf->t.t0, leaf->t.t1);
        visited += static_cast<int>(count);
    }
    return visited == 8 ? 0 : 1;  // the ray along x passes through all eight crates
}

// Positive and negative compile-time checks of the concepts users plug their types into.
#include <sylva/bih/payload.hpp>
#include <sylva/core/concepts.hpp>
#include <sylva/core/executor.hpp>
#include <sylva/elements/box.hpp>
#include <sylva/elements/rbf.hpp>
#include <sylva/elements/sphere.hpp>

namespace user {
// Bounded through a free function found by argument-dependent lookup.
struct Point {
    sylva::vec3 p;
};
inline sylva::Aabb bounds(const Point& x) { return {x.p, x.p}; }
inline std::optional<sylva::Interval> intersect(const Point&, const sylva::Ray&, sylva::Interval) { return {}; }

struct NoBounds {
    int x;
};
struct WrongBoundsType {
    int bounds() const { return 0; }
};
struct BoundsOnly {
    sylva::Aabb bounds() const { return {}; }
};
struct BadIntersect {  // returns bool, not optional<Interval>
    sylva::Aabb bounds() const { return {}; }
    bool intersect(const sylva::Ray&, sylva::Interval) const { return false; }
};
struct TooWidePayload {  // no kind
    template <class E>
    std::uint64_t encode(std::span<const E>, std::uint32_t) const { return 0; }
};
struct NotAnExecutor {
    std::size_t concurrency() const { return 1; }
};
}  // namespace user

using namespace sylva;
static_assert(Bounded<Sphere> && Intersectable<Sphere> && RayInteraction<Sphere>);
static_assert(Bounded<GaussianRbf> && Intersectable<GaussianRbf> && RayInteraction<GaussianRbf>);
static_assert(Bounded<BoxElement> && Intersectable<BoxElement> && !RayInteraction<BoxElement>);
static_assert(Bounded<user::Point> && Intersectable<user::Point>);
static_assert(!Bounded<user::NoBounds>);
static_assert(!Bounded<user::WrongBoundsType>);
static_assert(Bounded<user::BoundsOnly> && !Intersectable<user::BoundsOnly>);
static_assert(!Intersectable<user::BadIntersect>);
static_assert(!Bounded<int>);
static_assert(PayloadEncoder<bih::RangePayload, Sphere>);
static_assert(PayloadEncoder<ParticlePayload, Sphere>);
static_assert(PayloadEncoder<ParticlePayload, GaussianRbf>);
static_assert(!PayloadEncoder<ParticlePayload, BoxElement>);  // a box is not a radial particle
static_assert(!PayloadEncoder<user::TooWidePayload, Sphere>);
static_assert(!PayloadEncoder<bih::RangePayload, user::NoBounds>);
static_assert(Executor<SerialExecutor> && Executor<ThreadPool>);
static_assert(!Executor<user::NotAnExecutor>);
static_assert(!Executor<int>);
static_assert(RadialParticle<Sphere> && RadialParticle<GaussianRbf> && !RadialParticle<BoxElement>);

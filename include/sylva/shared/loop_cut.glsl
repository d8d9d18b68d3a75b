// sylva/shared/loop_cut.glsl -- GLSL only: whether the device's loop limiter cut this
// invocation's loops short.
//
// Lavapipe up to Mesa 22.3 (Debian 12's own) runs 8 invocations as one SIMD batch and ends every
// loop of the batch, silently, once 65,535 loop iterations have run in all of them together
// (docs/DESIGN.md, Vulkan runner; Mesa 25 and GPUs have no such limiter, vk::loops_limited).
// A loop it cuts leaves whatever state it had: a traversal may then end as if it were done, so
// a shader cannot tell a cut from its own status. What it can tell: once the limiter has run
// out, every loop stops after one iteration. A kernel calls sylva_loops_cut() after its work,
// in every invocation whatever its status, and marks (or runs again) the rays of a batch that
// was cut: never a short or wrong pixel. On a device without a limiter it is false.
#ifndef SYLVA_SHARED_LOOP_CUT_GLSL
#define SYLVA_SHARED_LOOP_CUT_GLSL

/// True when the loop limiter has run out for this invocation's batch: a loop of two
/// iterations, whose count the compiler cannot see, ran once.
bool sylva_loops_cut() {
    uint trips = 2u + (gl_NumWorkGroups.x >> 31u);  // 2 (fewer than 2^31 workgroups), not a constant
    uint ran = 0u;
    for (uint k = 0u; k < trips; k++) ran = ran + 1u;
    return ran < trips;
}

#endif  // SYLVA_SHARED_LOOP_CUT_GLSL

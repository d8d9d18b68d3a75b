// sylva/shared/octree_particles.h -- the particle integrator of sylva/shared/particles.h
// (Kinkelin 4.2, after Kaehler et al.: front-to-back compositing, no global sort) over the
// element octree (sylva/shared/octree_elem_iter.h) instead of the BIH: the one integrator of
// sylva/shared/index_particles.h (which documents the order: a brute-force sort's) with the
// octree as its index (sylva/shared/element_octree.h). Records: the 8-word particle records of
// particles.h in the element order the octree was built over (element e is record e).
//
// In GLSL it defines SylvaIndexIter as SylvaOctElemIter unless the shader did (one index a shader).
#ifndef SYLVA_SHARED_OCTREE_PARTICLES_H
#define SYLVA_SHARED_OCTREE_PARTICLES_H

#include "sylva/shared/element_octree.h"
#ifndef __cplusplus
#ifndef SylvaIndexIter
#define SylvaIndexIter SylvaOctElemIter
#endif
#endif
#include "sylva/shared/index_particles.h"

SYLVA_BEGIN_NAMESPACE

/// Renders one ray through a particle element octree (`records` 8-word records in `elems`, at
/// most SYLVA_PARTICLE_MAX_RECORDS): sylva_index_render_particles over it.
SYLVA_FN vec4 sylva_octe_render_particles(SYLVA_BUF(words), uint word_count, SYLVA_BUF(elems), uint records, vec3 o,
                                          vec3 d, float t_min, float t_max, float alpha_stop, SYLVA_OUT(uint) steps,
                                          SYLVA_OUT(uint) status) {
    return sylva_index_render_particles SYLVA_INDEX_TARGS(SylvaOctElemIter)(
        SYLVA_PASS_BUF(words), word_count, SYLVA_PASS_BUF(elems), records, o, d, t_min, t_max, alpha_stop, steps,
        status);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_OCTREE_PARTICLES_H

// sylva/shared/dvr_classify.h -- classification of one volume sample as the parameter block says:
// the transfer-function kind (word 36: RGBA8 table, float RGBA table or hook; tf.h) and the
// opacity correction (word 37).
//
// Opacity correction. The TF's alpha is the opacity of a sample of length `unit` (world units,
// word 17). SYLVA_OPACITY_POWER (default) gives a segment of `units` = length / unit such
// lengths the opacity 1 - (1 - alpha)^units (Kinkelin 4.3), so images do not depend on dt
// beyond sampling error; it costs an exp2 and a log2 a sample, which GPUs compute within a few
// ulps of the host's libm (host/device colours agree within 5e-5, not bit for bit).
// SYLVA_OPACITY_NONE uses alpha as each sample's opacity whatever dt and unit are (the
// convention of renderers that composite alpha per step, e.g. a NanoVDB sample loop); images
// then depend on dt, and host and device agree bit for bit (no transcendental).
#ifndef SYLVA_SHARED_DVR_CLASSIFY_H
#define SYLVA_SHARED_DVR_CLASSIFY_H

#include "sylva/shared/dvr_common.h"
#include "sylva/shared/tf.h"

SYLVA_BEGIN_NAMESPACE

/// Straight RGBA of normalised density d under the parameter block's transfer function.
SYLVA_FN vec4 sylva_dvr_classify(SYLVA_BUF(tf), SylvaDvrParams p, float d) {
    return sylva_tf_classify(SYLVA_PASS_BUF(tf), p.tf_kind, p.tf_entries, d);
}

/// Opacity of a segment `units` unit lengths long whose unit-length opacity is alpha, with the
/// parameter block's opacity correction (see the top).
SYLVA_FN float sylva_dvr_opacity(SylvaDvrParams p, float alpha, float units) {
    if (p.opacity == SYLVA_OPACITY_NONE) return sylva_tf_clamp01(alpha);
    return sylva_dvr_correct(alpha, units);
}

SYLVA_END_NAMESPACE

#endif  // SYLVA_SHARED_DVR_CLASSIFY_H

#version 460
// The reference DVR marcher (sylva/shared/dvr.h) over a density grid: the kernel of
// sylva/shared/dvr_main.glsl (bindings and specialization constants described there), with the
// library's transfer-function tables and no hooks.
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/dvr_main.glsl"

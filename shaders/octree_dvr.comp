#version 460
// DVR and first-hit isosurfaces over the bricked octree: the kernel of
// sylva/shared/octree_dvr_main.glsl (bindings, push and specialization constants described
// there), with the library's transfer-function tables and no hooks.
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/octree_dvr_main.glsl"

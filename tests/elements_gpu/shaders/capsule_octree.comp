#version 460
// The generic element kernel for the capsule over the element octree (element_octree.h).
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/element_prologue.glsl"
#include "capsule.h"
#include "sylva/shared/element_octree.h"
#define SylvaElem Capsule
#define SylvaIndexIter SylvaOctElemIter
#include "sylva/shared/element_main.glsl"

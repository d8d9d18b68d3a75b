#version 460
// The generic element kernel for the capsule over the kd-tree over elements (element_kd.h).
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/element_prologue.glsl"
#include "capsule.h"
#include "sylva/shared/element_kd.h"
#define SylvaElem Capsule
#define SylvaIndexIter SylvaKdElemIter
#include "sylva/shared/element_main.glsl"

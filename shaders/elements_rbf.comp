#version 460
// The generic element kernel (sylva/shared/element_main.glsl) for the library's GaussianRbf
// (sylva/shared/sphere_element.h): hits in order and front-to-back images, sylva::vk::ElementKernel.
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/element_prologue.glsl"
#include "sylva/shared/sphere_element.h"
#define SylvaElem GaussianRbf
#include "sylva/shared/element_main.glsl"

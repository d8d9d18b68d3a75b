#version 460
// The generic element kernel (sylva/shared/element_main.glsl) for the library's Sphere over
// the kd-tree over elements (element_kd.h): sylva::vk::ElementKernel with a vk::DeviceElementIndex
// (sylva-render --order exact --index kd --backend vulkan).
#extension GL_GOOGLE_include_directive : require
#include "sylva/shared/element_prologue.glsl"
#include "sylva/shared/sphere_element.h"
#include "sylva/shared/element_kd.h"
#define SylvaElem Sphere
#define SylvaIndexIter SylvaKdElemIter
#include "sylva/shared/element_main.glsl"

// Every shared header compiles as C++ on its own (the GLSL side is checked by the shader build).
#include <sylva/shared/lang.h>
#include <sylva/shared/bih_layout.h>
#include <sylva/shared/bih_iter.h>
#include <sylva/shared/particles.h>
#include <sylva/shared/camera.h>
#include <sylva/shared/voxel.h>
#include <sylva/shared/tf.h>
#include <sylva/shared/grid_sample.h>
#include <sylva/shared/dvr_common.h>
#include <sylva/shared/dvr.h>
#include <sylva/shared/bih_dvr.h>
#include <sylva/shared/kd_layout.h>
#include <sylva/shared/kd_iter.h>
#include <sylva/shared/kd_dvr.h>
#include <sylva/shared/kd_local_boxes.h>

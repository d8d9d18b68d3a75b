# examples.sylva_render.particles_same_image_*: sylva-render draws the same particles with
# --index kd and --index octree (both the exact (t_c, index) order) into byte-identical PNGs,
# still (RUN=still) and after --animate 3 with --update refit and rebuild (RUN=animate: the four
# kd/octree x refit/rebuild images are identical; the BIH's animation runs both updates).
# -DEXE=sylva-render -DOUT=dir -DRUN=still|animate
function(render tag)
  execute_process(COMMAND ${EXE} --count 20000 --size 160x120 --alpha-stop 2 --quiet -o ${OUT}/pi_${RUN}_${tag}.png ${ARGN}
                  RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "sylva-render ${ARGN} failed (${rc}): ${err}")
  endif()
endfunction()
function(same a b)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/pi_${RUN}_${a}.png ${OUT}/pi_${RUN}_${b}.png
                  RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "--index ${a} and ${b} images differ (${OUT}/pi_${RUN}_${a}.png, ${OUT}/pi_${RUN}_${b}.png)")
  endif()
endfunction()
file(MAKE_DIRECTORY ${OUT})
if(RUN STREQUAL "still")
  render(kd --index kd)
  render(octree --index octree)
  render(bih --index bih)
  same(kd octree)
else()
  foreach(u refit rebuild)
    render(kd_${u} --index kd --animate 3 --update ${u})
    render(octree_${u} --index octree --animate 3 --update ${u})
    render(bih_${u} --index bih --animate 3 --update ${u})
  endforeach()
  same(kd_refit kd_rebuild)
  same(kd_refit octree_refit)
  same(kd_refit octree_rebuild)
endif()

# sylva-render --order exact|leaf (issue 14): the three particle indices give the same image
# through the generic element kernel, on the host and on Vulkan, still and moving (--animate: lavapipe
# against the host per index) (examples/particle_order_check.cmake); refused combinations.
set(_po_runs host animate leaf)
if(SYLVA_WITH_VULKAN)
  list(APPEND _po_runs vulkan)
endif()
foreach(run ${_po_runs})
  add_test(NAME examples.sylva_render.particle_order_${run}
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:sylva-render> -DDIFF=$<TARGET_FILE:sylva-image-diff>
                   -DOUT=${CMAKE_CURRENT_BINARY_DIR}/render-tests/order_${run} -DRUN=${run}
                   -P ${CMAKE_CURRENT_SOURCE_DIR}/particle_order_check.cmake)
  set_tests_properties(examples.sylva_render.particle_order_${run} PROPERTIES LABELS "plugins"
                       ENVIRONMENT "SYLVA_VULKAN_DEVICE=cpu")
endforeach()
if(SYLVA_WITH_VULKAN)
  set_tests_properties(examples.sylva_render.particle_order_vulkan PROPERTIES LABELS "plugins;vulkan")
  # --animate 3 on lavapipe against the host, last frames compared (one context and kernel a run).
  foreach(index bih kd octree leaf)
    set(_po_name examples.sylva_render.particle_order_vulkan_animate_${index})
    add_test(NAME ${_po_name}
             COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:sylva-render> -DDIFF=$<TARGET_FILE:sylva-image-diff>
                     -DOUT=${CMAKE_CURRENT_BINARY_DIR}/render-tests/order_vulkan_animate_${index} -DRUN=vulkan_animate
                     -DINDEX=${index} -P ${CMAKE_CURRENT_SOURCE_DIR}/particle_order_check.cmake)
    set_tests_properties(${_po_name} PROPERTIES LABELS "plugins;vulkan" ENVIRONMENT "SYLVA_VULKAN_DEVICE=cpu")
  endforeach()
endif()
sylva_render_test(animate_volume RC 2 ERR "--animate moves particles .--index bih, kd or octree., not volumes"
  ARGS --volume procedural --animate 2 -o ${_out}/x.png)
sylva_render_test(particle_order_leaf_kd_vulkan RC 2 ERR "--order leaf --index kd renders particles on --backend cpu only"
  ARGS --count 100 --index kd --order leaf --backend vulkan -o ${_out}/x.png)
sylva_render_test(particle_order_leaf_kd_vulkan_animate RC 2
  ERR "--order leaf --index kd renders particles on --backend cpu only"
  ARGS --count 100 --index kd --order leaf --backend vulkan --animate 2 -o ${_out}/x.png)
sylva_render_test(particle_order_volume RC 2 ERR "--order exact.leaf orders particles, not volumes"
  ARGS --volume procedural --order leaf -o ${_out}/x.png)

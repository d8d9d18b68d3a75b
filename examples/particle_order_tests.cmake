# sylva-render --order exact|leaf (issue 14): the three particle indices give the same image
# through the generic element kernel, on the host and on Vulkan (examples/particle_order_check.cmake).
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
endif()
sylva_render_test(particle_order_volume RC 2 ERR "--order exact.leaf orders particles, not volumes"
  ARGS --volume procedural --order leaf -o ${_out}/x.png)

# sylva-render end to end: default scene on both backends, the real halo, and bad input.
set(_out ${CMAKE_CURRENT_BINARY_DIR}/render-tests)
file(MAKE_DIRECTORY ${_out})
set(_check ${CMAKE_CURRENT_SOURCE_DIR}/run_check.cmake)
set(_keys "index;backend;elements;nodes;max_depth;bytes;build_ms;render_ms;rays_per_s")
set(_positive "elements;nodes;max_depth;bytes;rays_per_s")
set(_data ${PROJECT_SOURCE_DIR}/../shared/data)

function(sylva_render_test name)
  cmake_parse_arguments(A "" "RC;ERR;MAKE_FILE;MAKE_BYTES;NEED;ENV" "ARGS;FILES;JSON" ${ARGN})
  list(JOIN A_ARGS "|" joined)
  set(defs -DEXE=$<TARGET_FILE:sylva-render> "-DARGS=${joined}")
  if(DEFINED A_RC)
    list(APPEND defs -DEXPECT_RC=${A_RC})
  endif()
  foreach(v ERR MAKE_FILE MAKE_BYTES NEED)
    if(A_${v})
      list(APPEND defs "-D${v}=${A_${v}}")
    endif()
  endforeach()
  if(A_ERR)
    list(APPEND defs "-DEXPECT_ERR=${A_ERR}")
  endif()
  if(A_FILES)
    list(JOIN A_FILES "|" files)
    list(APPEND defs "-DFILES=${files}")
  endif()
  if(A_JSON)
    string(REPLACE ";" "|" keys "${_keys}")
    string(REPLACE ";" "|" positive "${_positive}")
    list(APPEND defs "-DJSON=${A_JSON}" "-DJSON_KEYS=${keys}" "-DJSON_POSITIVE=${positive}")
  endif()
  add_test(NAME examples.sylva_render.${name} COMMAND ${CMAKE_COMMAND} ${defs} -P ${_check})
  set_tests_properties(examples.sylva_render.${name} PROPERTIES SKIP_RETURN_CODE 77 ENVIRONMENT "SYLVA_VULKAN_DEVICE=cpu"
                       LABELS "plugins")  # OpenImageIO loads format plugins
endfunction()

foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  sylva_render_test(default_${backend}
    ARGS --backend ${backend} --count 200000 --size 240x180 --quiet -o ${_out}/default_${backend}.png
         --heatmap ${_out}/default_${backend}_heat.png --stats-json ${_out}/default_${backend}.json
    FILES ${_out}/default_${backend}.png ${_out}/default_${backend}_heat.png
    JSON ${_out}/default_${backend}.json)
endforeach()
sylva_render_test(halo_cpu
  NEED ${_data}/dark_matter_halo_32314x3_float32.raw
  ARGS --particles ${_data}/dark_matter_halo_32314x3_float32.raw --size 240x180 --quiet -o ${_out}/halo.exr
       --stats-json ${_out}/halo.json
  FILES ${_out}/halo.exr JSON ${_out}/halo.json)
sylva_render_test(missing_file RC 1 ERR "cannot read particle file .*nope\\.raw"
  ARGS --particles ${_out}/nope.raw -o ${_out}/x.png)
sylva_render_test(wrong_size RC 1 ERR "not a whole number of float32 xyz triples"
  MAKE_FILE ${_out}/odd.raw MAKE_BYTES 13 ARGS --particles ${_out}/odd.raw -o ${_out}/x.png)
sylva_render_test(truncated RC 1 ERR "holds 1 points but its name says 5"
  MAKE_FILE ${_out}/cut_5x3_float32.raw MAKE_BYTES 12 ARGS --particles ${_out}/cut_5x3_float32.raw -o ${_out}/x.png)
sylva_render_test(bad_option RC 2 ERR "unknown option '--frobnicate'" ARGS --frobnicate -o ${_out}/x.png)
sylva_render_test(bad_backend RC 2 ERR "--backend: 'metal' is not one of cpu\\|vulkan" ARGS --backend metal -o ${_out}/x.png)
sylva_render_test(no_output RC 2 ERR "-o OUT.png is required" ARGS --count 10)
sylva_render_test(unwritable RC 1 ERR "cannot write /nonexistent-dir/x.png"
  ARGS --count 1000 --size 16x16 --quiet -o /nonexistent-dir/x.png)

# examples.sylva_render.iso_packets: sylva-render --index implicit-kd --packets 1|4|8|16 on the host
# (issue 11, Wald section 4.3): packets of 4, 8 (the default) and 16 rays write PNGs byte-identical
# to single rays' (--packets 1) and the stats JSON's packet_lanes says which ran, with fewer
# traversal steps the more rays a packet holds.
#   cmake -DEXE=<sylva-render> -DOUT=<dir> -P iso_packets_check.cmake
file(MAKE_DIRECTORY ${OUT})
set(previous_steps "")
foreach(lanes 1 4 8 16)
  set(args --volume procedural:ml --index implicit-kd --iso 0.3,0.6 --size 97x71 --quiet
           -o ${OUT}/iso_${lanes}.png --stats-json ${OUT}/iso_${lanes}.json)
  if(NOT lanes EQUAL 8)  # 8: the default, not given
    list(APPEND args --packets ${lanes})
  endif()
  execute_process(COMMAND ${EXE} ${args} RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "sylva-render ${args} failed (${rc}): ${err}")
  endif()
  file(READ ${OUT}/iso_${lanes}.json json)
  string(JSON got GET "${json}" packet_lanes)
  string(JSON steps GET "${json}" traversal_steps)
  string(JSON hits GET "${json}" hits)
  message(STATUS "--packets ${lanes}: packet_lanes ${got}, ${steps} steps, ${hits} hits")
  if(NOT got EQUAL lanes)
    message(FATAL_ERROR "--packets ${lanes}: the stats say packet_lanes ${got}")
  endif()
  if(hits LESS 1000)
    message(FATAL_ERROR "--packets ${lanes}: only ${hits} hits (the scene shows the surfaces)")
  endif()
  if(NOT previous_steps STREQUAL "" AND NOT steps LESS previous_steps)
    message(FATAL_ERROR "--packets ${lanes}: ${steps} traversal steps, not fewer than ${previous_steps}")
  endif()
  set(previous_steps ${steps})
  if(NOT lanes EQUAL 1)
    execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/iso_1.png ${OUT}/iso_${lanes}.png RESULT_VARIABLE same)
    if(NOT same EQUAL 0)
      message(FATAL_ERROR "--packets ${lanes}: the image differs from single rays' (${OUT}/iso_1.png)")
    endif()
  endif()
endforeach()

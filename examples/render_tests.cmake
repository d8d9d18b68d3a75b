# sylva-render end to end: default scene on both backends, the real halo, and bad input.
set(_out ${CMAKE_CURRENT_BINARY_DIR}/render-tests)
file(MAKE_DIRECTORY ${_out})
set(_check ${CMAKE_CURRENT_SOURCE_DIR}/run_check.cmake)
set(_keys "index;backend;elements;nodes;max_depth;bytes;build_ms;render_ms;rays_per_s")
set(_positive "elements;nodes;max_depth;bytes;rays_per_s")
set(_data ${PROJECT_SOURCE_DIR}/../shared/data)

function(sylva_render_test name)
  cmake_parse_arguments(A "KEYS_ONLY" "RC;ERR;MAKE_FILE;MAKE_BYTES;NEED;ENV;FIXTURE"
                        "ARGS;FILES;JSON;EXTRA_KEYS;JSON_MIN;JSON_EQUAL;JSON_TYPE" ${ARGN})
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
  foreach(v JSON_MIN JSON_EQUAL JSON_TYPE)
    if(A_${v})
      string(REPLACE ";" "|" joined_v "${A_${v}}")
      list(APPEND defs "-D${v}=${joined_v}")
    endif()
  endforeach()
  if(A_JSON)
    string(REPLACE ";" "|" keys "${_keys};${A_EXTRA_KEYS}")
    string(REPLACE ";" "|" positive "${_positive}")
    list(APPEND defs "-DJSON=${A_JSON}" "-DJSON_KEYS=${keys}")
    if(NOT A_KEYS_ONLY)  # the reference marcher has no index: nodes and depth are 0
      list(APPEND defs "-DJSON_POSITIVE=${positive}")
    endif()
  endif()
  add_test(NAME examples.sylva_render.${name} COMMAND ${CMAKE_COMMAND} ${defs} -P ${_check})
  set_tests_properties(examples.sylva_render.${name} PROPERTIES SKIP_RETURN_CODE 77 ENVIRONMENT "SYLVA_VULKAN_DEVICE=cpu"
                       LABELS "plugins")  # OpenImageIO loads format plugins
  if(A_FIXTURE)
    set_tests_properties(examples.sylva_render.${name} PROPERTIES FIXTURES_REQUIRED ${A_FIXTURE})
  endif()
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

# Volumes (issue 3): the procedural volume on both backends in every mode, a real CT volume, bad input.
foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  foreach(mode single multi iso none)
    set(extra --mode dvr --dvr ${mode})
    set(keys_only "")
    if(mode STREQUAL "iso")
      set(extra --mode iso --iso 0.3)
    elseif(mode STREQUAL "none")
      set(extra --mode dvr --index none)
      set(keys_only KEYS_ONLY)
    endif()
    sylva_render_test(volume_${mode}_${backend} ${keys_only}
      ARGS --backend ${backend} ${extra} --size 96x72 --quiet -o ${_out}/volume_${mode}_${backend}.png
           --heatmap ${_out}/volume_${mode}_${backend}_heat.png --stats-json ${_out}/volume_${mode}_${backend}.json
      FILES ${_out}/volume_${mode}_${backend}.png ${_out}/volume_${mode}_${backend}_heat.png
      JSON ${_out}/volume_${mode}_${backend}.json)
  endforeach()
endforeach()
sylva_render_test(volume_lobster_cpu
  NEED ${_data}/lobster_301x324x56_uint8.raw
  ARGS --volume ${_data}/lobster_301x324x56_uint8.raw --spacing 1,1,1.4 --size 96x72 --quiet -o ${_out}/lobster.png
       --stats-json ${_out}/lobster.json
  FILES ${_out}/lobster.png JSON ${_out}/lobster.json)
sylva_render_test(volume_wrong_size RC 1 ERR "13 bytes, but 2x3x4 uint8 voxels need 24 bytes"
  MAKE_FILE ${_out}/small_2x3x4_uint8.raw MAKE_BYTES 13 ARGS --volume ${_out}/small_2x3x4_uint8.raw -o ${_out}/x.png)
sylva_render_test(volume_missing RC 1 ERR "nope_8x8x8_uint8\\.raw"
  ARGS --volume ${_out}/nope_8x8x8_uint8.raw -o ${_out}/x.png)
sylva_render_test(volume_bad_name RC 1 ERR "NAME_XxYxZ_TYPE"
  MAKE_FILE ${_out}/volume.raw MAKE_BYTES 8 ARGS --volume ${_out}/volume.raw -o ${_out}/x.png)
sylva_render_test(volume_empty ERR "nothing visible.*threshold +0.9 .*no voxel reaches it"  # constant 120: density 1
  MAKE_FILE ${_out}/low_2x2x2_uint8.raw MAKE_BYTES 8                                  # (auto), so type range
  ARGS --volume ${_out}/low_2x2x2_uint8.raw --range type --threshold 0.9 --size 96x72 -o ${_out}/empty.png
       --stats-json ${_out}/empty.json
  FILES ${_out}/empty.png JSON ${_out}/empty.json KEYS_ONLY JSON_EQUAL elements=0 visible_pixels=0)
sylva_render_test(volume_index_none_particles RC 2 ERR "--index none renders volumes only"
  ARGS --index none -o ${_out}/x.png)
sylva_render_test(volume_bad_procedural RC 1 ERR "unknown procedural volume"
  ARGS --volume procedural:teapot -o ${_out}/x.png)

# Volumes with a kd-tree index (issue 4): the marcher with empty-space skipping on the procedural
# volume, both builders, shallow and deep trees, both backends (kd-binned on Vulkan computes its
# local boxes on the device), leaf boxes drawn, a transfer-function replay with rebuilds, bad input.
file(WRITE ${_out}/tf_soft.txt "# density r g b a\n0.0 0 0 0 0\n0.08 0.5 0.3 0.2 0\n0.3 0.9 0.6 0.4 0.25\n1.0 1 1 1 0.9\n")
file(WRITE ${_out}/tf_band.json "{\"points\": [[0.25, 0, 0, 0, 0], [0.4, 1, 0.5, 0.2, 0.7], [0.55, 0, 0, 0, 0]], \"entries\": 512}\n")
file(WRITE ${_out}/tf_clear.txt "0.0 1 1 1 0\n1.0 1 1 1 0\n")
set(_kd_keys "occupancy_percent;culled_percent;leaves;max_depth;codes_ms;occupancy_ms;split_ms;bytes;tf_sequence")
foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  foreach(builder vidal binned)
    foreach(depth shallow deep)
      set(_n volume_kd_${builder}_${depth}_${backend})
      set(_keys_only "")
      if(depth STREQUAL "shallow")  # Vidal's criteria keep this sparse but spread volume one leaf (depth 0)
        set(_keys_only KEYS_ONLY)
      endif()
      sylva_render_test(${_n} ${_keys_only}
        ARGS --index kd-${builder} --kd ${depth} --backend ${backend} --size 96x72 --repeat 2 --quiet -o ${_out}/${_n}.png
             --boxes ${_out}/${_n}_boxes.png --heatmap ${_out}/${_n}_heat.png --stats-json ${_out}/${_n}.json
        FILES ${_out}/${_n}.png ${_out}/${_n}_boxes.png ${_out}/${_n}_heat.png
        JSON ${_out}/${_n}.json EXTRA_KEYS ${_kd_keys})
    endforeach()
  endforeach()
  sylva_render_test(volume_kd_tf_sequence_${backend}
    ARGS --index kd-binned --backend ${backend} --size 64x48 --quiet -o ${_out}/kd_seq_${backend}.png
         --tf-sequence ${_out}/tf_soft.txt,${_out}/tf_band.json --stats-json ${_out}/kd_seq_${backend}.json
    FILES ${_out}/kd_seq_${backend}.png ${_out}/kd_seq_${backend}_tf1.png ${_out}/kd_seq_${backend}_tf2.png
    JSON ${_out}/kd_seq_${backend}.json EXTRA_KEYS ${_kd_keys})
endforeach()
sylva_render_test(volume_kd_ml_threshold_cpu
  ARGS --volume procedural:ml --index kd-vidal --kd-classify threshold --threshold 0.5 --tf-preset ramp --size 64x48
       --quiet -o ${_out}/kd_ml.png --stats-json ${_out}/kd_ml.json
  FILES ${_out}/kd_ml.png JSON ${_out}/kd_ml.json EXTRA_KEYS ${_kd_keys})
sylva_render_test(volume_kd_aneurism_cpu
  NEED ${_data}/aneurism_256x256x256_uint8.raw
  ARGS --volume ${_data}/aneurism_256x256x256_uint8.raw --index kd-vidal --size 96x72 --quiet -o ${_out}/kd_aneurism.png
       --boxes ${_out}/kd_aneurism_boxes.png --stats-json ${_out}/kd_aneurism.json
  FILES ${_out}/kd_aneurism.png ${_out}/kd_aneurism_boxes.png JSON ${_out}/kd_aneurism.json EXTRA_KEYS ${_kd_keys})
sylva_render_test(volume_kd_clear_tf RC 1 ERR "the transfer function has no opaque entry"
  ARGS --index kd-vidal --tf ${_out}/tf_clear.txt --size 16x16 -o ${_out}/x.png)
sylva_render_test(volume_kd_clear_tf_sequence RC 1 ERR "--tf-sequence .*tf_clear\\.txt: the transfer function has no opaque entry"
  ARGS --index kd-binned --size 16x16 --quiet --tf-sequence ${_out}/tf_soft.txt,${_out}/tf_clear.txt -o ${_out}/x.png)
sylva_render_test(volume_kd_missing_tf RC 1 ERR "nope_tf\\.txt"
  ARGS --index kd-vidal --size 16x16 --quiet --tf-sequence ${_out}/nope_tf.txt -o ${_out}/x.png)
sylva_render_test(volume_kd_iso RC 2 ERR "--index kd-vidal renders --mode dvr only"
  ARGS --index kd-vidal --mode iso -o ${_out}/x.png)
sylva_render_test(volume_kd_particles RC 2 ERR "--index kd-binned renders volumes only"
  ARGS --index kd-binned --particles ${_out}/nope.raw -o ${_out}/x.png)
sylva_render_test(volume_kd_boxes_without_kd RC 2 ERR "--boxes and --tf-sequence need a kd-tree"
  ARGS --mode dvr --boxes ${_out}/b.png -o ${_out}/x.png)
sylva_render_test(volume_kd_bad_depth RC 2 ERR "--kd: 'medium' is not one of shallow\\|deep"
  ARGS --index kd-vidal --kd medium -o ${_out}/x.png)

# Value ranges (issue 10): a 12-bit CT in uint16 and float32 volumes with negative and large values,
# written by make_test_volumes, render a visible image by default with every index on both
# backends (at least 5 % of the pixels with alpha >= 1/255), and the stats say which range was used.
# NRRD min:/max: win over the data's range; --range type shows nothing and says so (exit 0).
add_executable(make_test_volumes ${CMAKE_CURRENT_SOURCE_DIR}/sylva_render/make_test_volumes.cpp)
target_link_libraries(make_test_volumes PRIVATE sylva_project_options)
set(_rv ${_out}/range)
add_test(NAME examples.sylva_render.range_volumes COMMAND make_test_volumes ${_rv})
set_tests_properties(examples.sylva_render.range_volumes PROPERTIES FIXTURES_SETUP sylva_range_volumes)
set(_rv_min_visible 346)  # 5 % of 96 x 72
set(_rv_cases "ct12|ct12_48x48x40_uint16.raw|0|3926" "signed|signed_40x40x40_float32.raw|-1|1"
              "large|large_40x40x40_float32.raw|0|1000000")
foreach(case IN LISTS _rv_cases)
  string(REPLACE "|" ";" case "${case}")
  list(GET case 0 what)
  list(GET case 1 file)
  list(GET case 2 lo)
  list(GET case 3 hi)
  foreach(backend cpu vulkan)
    if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
      continue()
    endif()
    foreach(index bih kd-vidal kd-binned none)
      set(_n range_${what}_${index}_${backend})
      set(_keys_only "")
      if(index STREQUAL "none")
        set(_keys_only KEYS_ONLY)
      endif()
      sylva_render_test(${_n} ${_keys_only} FIXTURE sylva_range_volumes
        ARGS --volume ${_rv}/${file} --index ${index} --backend ${backend} --size 96x72 --quiet -o ${_rv}/${_n}.png
             --stats-json ${_rv}/${_n}.json
        FILES ${_rv}/${_n}.png JSON ${_rv}/${_n}.json
        JSON_MIN visible_pixels=${_rv_min_visible}
        JSON_EQUAL value_range.0=${lo} value_range.1=${hi} "value_range_source=data min/max")
    endforeach()
  endforeach()
endforeach()
sylva_render_test(range_ct12_nrrd_minmax FIXTURE sylva_range_volumes
  ARGS --volume ${_rv}/ct12.nrrd --size 96x72 --quiet -o ${_rv}/ct12_nrrd.png --stats-json ${_rv}/ct12_nrrd.json
  FILES ${_rv}/ct12_nrrd.png JSON ${_rv}/ct12_nrrd.json
  JSON_MIN visible_pixels=${_rv_min_visible}
  JSON_EQUAL value_range.0=0 value_range.1=4095 "value_range_source=file min/max")
sylva_render_test(range_ct12_explicit FIXTURE sylva_range_volumes
  ARGS --volume ${_rv}/ct12_48x48x40_uint16.raw --range 0,4095 --index kd-binned --size 96x72 --quiet
       -o ${_rv}/ct12_explicit.png --stats-json ${_rv}/ct12_explicit.json
  FILES ${_rv}/ct12_explicit.png JSON ${_rv}/ct12_explicit.json
  JSON_MIN visible_pixels=${_rv_min_visible} JSON_EQUAL value_range.1=4095 value_range_source=explicit)
foreach(index bih kd-binned none)
  set(_n range_ct12_type_${index})
  sylva_render_test(${_n} KEYS_ONLY FIXTURE sylva_range_volumes
    ERR "nothing visible: all 96x72 pixels are fully transparent.*\\[0, 65535\\] \\(type range\\).*--range auto"
    ARGS --volume ${_rv}/ct12_48x48x40_uint16.raw --range type --index ${index} --size 96x72 --quiet
         -o ${_rv}/${_n}.png --stats-json ${_rv}/${_n}.json
    FILES ${_rv}/${_n}.png JSON ${_rv}/${_n}.json JSON_EQUAL visible_pixels=0 value_range.1=65535)
endforeach()
sylva_render_test(range_iso_type FIXTURE sylva_range_volumes
  ERR "nothing visible.*iso value +0.3 \\(raw value 19660.5\\).*an --iso value in"
  ARGS --volume ${_rv}/ct12_48x48x40_uint16.raw --range type --mode iso --iso 0.3 --size 32x24 --quiet
       -o ${_rv}/iso_type.png FILES ${_rv}/iso_type.png)
sylva_render_test(range_bad RC 2 ERR "--range: value range '4095,0': LO must be below HI"
  ARGS --volume ${_rv}/ct12.nrrd --range 4095,0 -o ${_out}/x.png)
sylva_render_test(range_bad_word RC 2 ERR "--range: value range 'full' is not auto, type or LO,HI"
  ARGS --volume ${_rv}/ct12.nrrd --range full -o ${_out}/x.png)
sylva_render_test(range_procedural RC 2 ERR "--range applies to volume files"
  ARGS --mode dvr --range 0,10 -o ${_out}/x.png)

# Exact isosurfaces (issue 11): Wald's implicit kd-tree and the reference cell DDA on both
# backends, one and several isovalues, the stats JSON's memory and traversal figures; the
# 12-bit CT; bad options.
set(_iso_keys "isos;index_bytes;data_bytes;cells_tested;traversal_steps;hits;levels")
foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  foreach(index implicit-kd dda)
    set(_n iso_${index}_${backend})
    sylva_render_test(${_n} KEYS_ONLY
      ARGS --volume procedural:ml --index ${index} --iso 0.3,0.6 --backend ${backend} --size 96x72 --quiet
           -o ${_out}/${_n}.png --heatmap ${_out}/${_n}_heat.png --stats-json ${_out}/${_n}.json
      FILES ${_out}/${_n}.png ${_out}/${_n}_heat.png JSON ${_out}/${_n}.json EXTRA_KEYS ${_iso_keys}
      JSON_MIN hits=1000 cells_tested=1000 visible_pixels=1000 data_bytes=8388608)
  endforeach()
endforeach()
sylva_render_test(iso_ct12_implicit_kd FIXTURE sylva_range_volumes
  ARGS --volume ${_rv}/ct12_48x48x40_uint16.raw --index implicit-kd --iso 0.5 --size 96x72 --quiet
       -o ${_rv}/iso_ct12.png --stats-json ${_rv}/iso_ct12.json
  FILES ${_rv}/iso_ct12.png JSON ${_rv}/iso_ct12.json EXTRA_KEYS ${_iso_keys}
  JSON_MIN visible_pixels=${_rv_min_visible} JSON_EQUAL value_range.1=3926 data_bytes=184320)
# The 12-bit CT read as stored (--grid native, the default: uint16, 2 bytes a sample) or as a float
# copy, on both backends (issue 17); that both give the same hits, bit for bit, is checked by
# test_iso_render (host) and test_iso_parity (lavapipe).
foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  foreach(grid native float32)
    if(grid STREQUAL "native")
      set(_grid_json grid_bytes=184320 grid_format=uint16)
    else()
      set(_grid_json grid_bytes=368640 grid_format=float32)
    endif()
    sylva_render_test(iso_grid_${grid}_ct12_${backend} FIXTURE sylva_range_volumes
      ARGS --volume ${_rv}/ct12_48x48x40_uint16.raw --index implicit-kd --iso 0.5 --grid ${grid} --backend ${backend}
           --size 96x72 --quiet -o ${_rv}/iso_grid_${grid}_${backend}.png --stats-json ${_rv}/iso_grid_${grid}_${backend}.json
      FILES ${_rv}/iso_grid_${grid}_${backend}.png JSON ${_rv}/iso_grid_${grid}_${backend}.json
      EXTRA_KEYS ${_iso_keys} grid_bytes grid_format
      JSON_MIN visible_pixels=${_rv_min_visible} JSON_EQUAL ${_grid_json} errors=0)
  endforeach()
endforeach()
# Packets (--packets 1|4|8|16, 8 by default on the host): the single rays' image byte for byte,
# fewer steps (examples/iso_packets_check.cmake); refused where no packets walk.
add_test(NAME examples.sylva_render.iso_packets
         COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:sylva-render> -DOUT=${_out}/iso_packets
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/iso_packets_check.cmake)
set_tests_properties(examples.sylva_render.iso_packets PROPERTIES LABELS "plugins")
sylva_render_test(iso_packets_dda RC 2 ERR "--packets: packets walk the implicit kd-tree on the host"
  ARGS --index dda --packets 4 -o ${_out}/x.png)
sylva_render_test(iso_packets_bad RC 2 ERR "--packets: '3' is not one of 1\\|4\\|8\\|16"
  ARGS --index implicit-kd --packets 3 -o ${_out}/x.png)
sylva_render_test(iso_grid_sparse RC 2 ERR "--grid sparse: the implicit kd-tree and the DDA read dense grids"
  ARGS --index implicit-kd --grid sparse -o ${_out}/x.png)
sylva_render_test(iso_outside FIXTURE sylva_range_volumes  # densities reach 3926 / 8000 = 0.49 only
  ERR "nothing visible.*iso value +0.8 \\(raw value 6400\\).*an --iso value in .0, 0.49"
  ARGS --volume ${_rv}/ct12_48x48x40_uint16.raw --range 0,8000 --index implicit-kd --iso 0.8 --size 96x72 --quiet
       -o ${_rv}/iso_outside.png FILES ${_rv}/iso_outside.png)
sylva_render_test(iso_too_many RC 2 ERR "--iso: '0.1,0.2,0.3,0.4,0.5' is not 1 to 4 values"
  ARGS --index implicit-kd --iso 0.1,0.2,0.3,0.4,0.5 -o ${_out}/x.png)
sylva_render_test(iso_dvr RC 2 ERR "--index dda renders isosurfaces"
  ARGS --index dda --mode dvr -o ${_out}/x.png)
sylva_render_test(iso_several_bih RC 2 ERR "several --iso values need --index implicit-kd or dda"
  ARGS --mode iso --iso 0.2,0.4 -o ${_out}/x.png)
sylva_render_test(iso_particles RC 2 ERR "--index implicit-kd renders volumes only"
  ARGS --index implicit-kd --particles ${_out}/nope.raw -o ${_out}/x.png)

# Gobbetti's bricked octree (issue 12): DVR and first-hit iso on both backends, the full-resolution
# cut and cuts chosen by view (--lod-pixels), both brick sizes; the stats JSON's octree figures;
# a volume file; bad options.
set(_oct_keys "bricks;octree_nodes;index_bytes;brick_bytes;cut_nodes")
foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  foreach(mode dvr iso)
    set(_n octree_${mode}_${backend})
    sylva_render_test(${_n}
      ARGS --volume procedural:ml --index octree --mode ${mode} --brick 16 --backend ${backend} --size 96x72 --quiet
           -o ${_out}/${_n}.png --heatmap ${_out}/${_n}_heat.png --stats-json ${_out}/${_n}.json
      FILES ${_out}/${_n}.png ${_out}/${_n}_heat.png JSON ${_out}/${_n}.json EXTRA_KEYS ${_oct_keys}
      JSON_MIN visible_pixels=1000 bricks=585 octree_nodes=585 cut_nodes=585 brick_bytes=18720000
      JSON_EQUAL cut_leaves=512 index_bytes=37520)
    set(_n octree_${mode}_lod_${backend})
    sylva_render_test(${_n}
      ARGS --volume procedural:ml --index octree --mode ${mode} --lod-pixels 1 --cut-nodes 300 --backend ${backend}
           --brick 16 --size 96x72 --quiet -o ${_out}/${_n}.png --stats-json ${_out}/${_n}.json
      FILES ${_out}/${_n}.png JSON ${_out}/${_n}.json EXTRA_KEYS ${_oct_keys}
      JSON_MIN visible_pixels=1000 cut_nodes=9 JSON_EQUAL lod_pixels=1 bricks=585)
  endforeach()
endforeach()
sylva_render_test(octree_ct12 FIXTURE sylva_range_volumes
  ARGS --volume ${_rv}/ct12_48x48x40_uint16.raw --index octree --brick 32 --lod-pixels 2 --size 96x72 --quiet
       -o ${_rv}/octree_ct12.png --stats-json ${_rv}/octree_ct12.json
  FILES ${_rv}/octree_ct12.png JSON ${_rv}/octree_ct12.json EXTRA_KEYS ${_oct_keys}
  JSON_MIN visible_pixels=${_rv_min_visible} JSON_EQUAL octree_nodes=9 bricks=9)
# --grid native (the default) keeps the uint8 aneurism's voxels in unorm8 bricks: a quarter of
# float32's 585 bricks x 36^3 words (brick_bytes = 585 x 11664 x 4); --grid float32 keeps float
# bricks. The images are the same (test_octree: unorm bricks == the native marcher bit for bit);
# out of core from the unorm8 tree too.
foreach(grid native float32)
  if(grid STREQUAL "native")
    set(_bf brick_format=unorm8 brick_bytes=27293760)
  else()
    set(_bf brick_format=float32 brick_bytes=109175040)
  endif()
  sylva_render_test(octree_bricks_${grid} NEED ${_data}/aneurism_256x256x256_uint8.raw
    ARGS --volume ${_data}/aneurism_256x256x256_uint8.raw --index octree --grid ${grid} --size 64x48 --quiet
         -o ${_out}/octree_bricks_${grid}.png --stats-json ${_out}/octree_bricks_${grid}.json
    FILES ${_out}/octree_bricks_${grid}.png JSON ${_out}/octree_bricks_${grid}.json EXTRA_KEYS brick_format ${_oct_keys}
    JSON_EQUAL ${_bf} bricks=585 errors=0 JSON_MIN visible_pixels=100)
endforeach()
sylva_render_test(octree_bricks_unorm8_ooc NEED ${_data}/aneurism_256x256x256_uint8.raw
  ARGS --volume ${_data}/aneurism_256x256x256_uint8.raw --index octree --frames 3 --size 64x48 --quiet
       -o ${_out}/octree_bricks_ooc.png --stats-json ${_out}/octree_bricks_ooc.json
  FILES ${_out}/octree_bricks_ooc.png JSON ${_out}/octree_bricks_ooc.json EXTRA_KEYS brick_format
  JSON_EQUAL brick_format=unorm8 errors=0 JSON_MIN visible_pixels=100)
sylva_render_test(octree_brick_8 RC 2 ERR "--brick: '8' is not one of 16\\|32"
  ARGS --index octree --brick 8 -o ${_out}/x.png)
sylva_render_test(octree_lod_without_octree RC 2 ERR "--lod-pixels needs --index octree"
  ARGS --mode dvr --lod-pixels 1 -o ${_out}/x.png)
sylva_render_test(octree_brick_without_octree RC 2 ERR "--brick needs --index octree"
  ARGS --index implicit-kd --brick 16 -o ${_out}/x.png)
sylva_render_test(octree_lod_zero RC 2 ERR "--lod-pixels: '0' is not a number in"
  ARGS --index octree --lod-pixels 0 -o ${_out}/x.png)
sylva_render_test(octree_cut_nodes_zero RC 2 ERR "--cut-nodes: '0' is not a number in"
  ARGS --index octree --cut-nodes 0 -o ${_out}/x.png)
# The transfer-function-aware refinement of the view's cut (octree/lod_error.hpp): on by default
# with --lod-pixels for DVR (1/64), off with 1; not with iso, without --lod-pixels or out of core.
# Marschner-Lobb's ripples are all detail: at 48x36 the projection alone stops at 9 nodes, the
# TF bound refines to more than a hundred (585 at the time of writing: all).
foreach(_e 0.015625 1)
  if(_e STREQUAL "1")
    set(_cut JSON_EQUAL max_tf_error=1 bricks=585 cut_nodes=9 JSON_MIN visible_pixels=500)
  else()
    set(_cut JSON_EQUAL max_tf_error=${_e} bricks=585 JSON_MIN visible_pixels=500 cut_nodes=100)
  endif()
  sylva_render_test(octree_lod_tf_${_e}
    ARGS --volume procedural:ml --index octree --lod-pixels 1 --max-tf-error ${_e} --brick 16 --size 48x36 --quiet
         -o ${_out}/octree_lod_tf_${_e}.png --stats-json ${_out}/octree_lod_tf_${_e}.json
    FILES ${_out}/octree_lod_tf_${_e}.png JSON ${_out}/octree_lod_tf_${_e}.json EXTRA_KEYS ${_oct_keys} ${_cut})
endforeach()
sylva_render_test(octree_max_tf_error_without_lod RC 2 ERR "--max-tf-error refines the view's cut: it needs --lod-pixels"
  ARGS --index octree --max-tf-error 0.1 -o ${_out}/x.png)
sylva_render_test(octree_max_tf_error_range RC 2 ERR "--max-tf-error: '2' is not a number in"
  ARGS --index octree --lod-pixels 1 --max-tf-error 2 -o ${_out}/x.png)
sylva_render_test(octree_max_tf_error_ooc RC 2 ERR "--max-tf-error: the out-of-core octree refines by projection only"
  ARGS --index octree --lod-pixels 1 --max-tf-error 0.1 --frames 2 -o ${_out}/x.png)
# The element octree over particles (--particles or --count with --index octree), both backends.
set(_octe_keys "octree_nodes;octree_levels;references;references_per_element;index_bytes;record_bytes")
foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  sylva_render_test(octree_particles_halo_${backend}
    NEED ${_data}/dark_matter_halo_32314x3_float32.raw
    ARGS --particles ${_data}/dark_matter_halo_32314x3_float32.raw --index octree --backend ${backend} --size 240x180
         --quiet -o ${_out}/halo_octree_${backend}.png --stats-json ${_out}/halo_octree_${backend}.json
    FILES ${_out}/halo_octree_${backend}.png JSON ${_out}/halo_octree_${backend}.json EXTRA_KEYS ${_octe_keys}
    JSON_MIN visible_pixels=1000 references=32314 index_bytes=1 record_bytes=1034048
    JSON_EQUAL index=octree elements=32314 errors=0)
  sylva_render_test(octree_particles_galaxy_${backend}
    ARGS --count 20000 --index octree --backend ${backend} --size 160x120 --quiet -o ${_out}/galaxy_octree_${backend}.png
         --heatmap ${_out}/galaxy_octree_heat_${backend}.png --stats-json ${_out}/galaxy_octree_${backend}.json
    FILES ${_out}/galaxy_octree_${backend}.png ${_out}/galaxy_octree_heat_${backend}.png
    JSON ${_out}/galaxy_octree_${backend}.json
    EXTRA_KEYS ${_octe_keys} JSON_MIN visible_pixels=1000 references=20000 record_bytes=640000
    JSON_EQUAL index=octree elements=20000 errors=0)
endforeach()
sylva_render_test(octree_particles_brick RC 2 ERR "--brick applies to the bricked octree of volumes, not to particles"
  ARGS --index octree --particles ${_out}/nope.raw --brick 16 -o ${_out}/x.png)
sylva_render_test(octree_several_isos RC 2 ERR "several --iso values need --index implicit-kd or dda"
  ARGS --index octree --mode iso --iso 0.2,0.4 -o ${_out}/x.png)
sylva_render_test(octree_multi RC 2 ERR "--dvr multi is BIH-DVR's"
  ARGS --index octree --dvr multi -o ${_out}/x.png)

# The out-of-core octree (issue 13, ooc_scene.hpp): progressive frames within small budgets on
# both backends, from the in-core tree and from a brick store made by sylva-store; bad options.
set(_ooc_keys "host_cache_bytes;device_pool_bytes;bricks_loaded;bricks_evicted;peak_rss_bytes;host_hit_rate;device_hit_rate;frames")
foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  sylva_render_test(octree_ooc_${backend}
    ARGS --volume procedural:ml --index octree --brick 16 --frames 12 --orbit --memory-budget 8M --device-budget 4M
         --backend ${backend} --size 96x72 --quiet -o ${_out}/octree_ooc_${backend}.png
         --stats-json ${_out}/octree_ooc_${backend}.json --frames-out ${_out}/octree_ooc_frames_${backend}
    FILES ${_out}/octree_ooc_${backend}.png ${_out}/octree_ooc_frames_${backend}/frame_0000.png
          ${_out}/octree_ooc_frames_${backend}/frame_0011.png JSON ${_out}/octree_ooc_${backend}.json EXTRA_KEYS ${_oct_keys} ${_ooc_keys}
    JSON_MIN visible_pixels=1000 bricks_loaded=8 device_pool_bytes=4000000 peak_rss_bytes=1000000
    JSON_EQUAL bad_bricks=0 errors=0 device_slots=131 memory_budget=8388608)
endforeach()
if(SYLVA_HAVE_STORE)  # sylva-store is defined after this file is included
  add_test(NAME examples.sylva_render.octree_ooc_store_clean COMMAND ${CMAKE_COMMAND} -E rm -rf ${_out}/ml64.store)
  add_test(NAME examples.sylva_render.octree_ooc_store_build
           COMMAND sylva-store build procedural:ml:64 -o ${_out}/ml64.store --brick 16)
  set_tests_properties(examples.sylva_render.octree_ooc_store_clean PROPERTIES FIXTURES_SETUP sylva_ooc_store_clean)
  set_tests_properties(examples.sylva_render.octree_ooc_store_build PROPERTIES FIXTURES_SETUP sylva_ooc_store
                       FIXTURES_REQUIRED sylva_ooc_store_clean)
  sylva_render_test(octree_ooc_store FIXTURE sylva_ooc_store
    ARGS --volume ${_out}/ml64.store --index octree --frames 10 --memory-budget 1M --device-budget 512K --size 96x72
         --quiet -o ${_out}/octree_ooc_store.png --stats-json ${_out}/octree_ooc_store.json
    FILES ${_out}/octree_ooc_store.png JSON ${_out}/octree_ooc_store.json EXTRA_KEYS ${_oct_keys} ${_ooc_keys}
    JSON_MIN visible_pixels=1000 bricks_loaded=8 JSON_EQUAL bad_bricks=0 errors=0 bricks=73)
endif()
if(SYLVA_HAVE_STORE)
  # A store of the uint8 aneurism: sylva-store's default brick format for integer volumes is
  # unorm16 (tests/store: the same words as octree::build's unorm16 tree); drawn out of core.
  set(_an ${_data}/aneurism_256x256x256_uint8.raw)
  add_test(NAME examples.sylva_render.octree_ooc_store_unorm16_clean
           COMMAND ${CMAKE_COMMAND} -E rm -rf ${_out}/aneurism.store)
  add_test(NAME examples.sylva_render.octree_ooc_store_unorm16_build
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:sylva-store> "-DARGS=build|${_an}|-o|${_out}/aneurism.store|--quiet"
                   -DNEED=${_an} "-DFILES=${_out}/aneurism.store/data.mdb" -P ${_check})
  set_tests_properties(examples.sylva_render.octree_ooc_store_unorm16_clean PROPERTIES FIXTURES_SETUP sylva_ooc_u16_clean)
  set_tests_properties(examples.sylva_render.octree_ooc_store_unorm16_build PROPERTIES FIXTURES_SETUP sylva_ooc_u16
                       FIXTURES_REQUIRED sylva_ooc_u16_clean SKIP_RETURN_CODE 77)
  sylva_render_test(octree_ooc_store_unorm16 FIXTURE sylva_ooc_u16 NEED ${_an}
    ARGS --volume ${_out}/aneurism.store --index octree --frames 3 --size 64x48 --quiet
         -o ${_out}/octree_ooc_store_unorm16.png --stats-json ${_out}/octree_ooc_store_unorm16.json
    FILES ${_out}/octree_ooc_store_unorm16.png JSON ${_out}/octree_ooc_store_unorm16.json EXTRA_KEYS brick_format ${_ooc_keys}
    JSON_EQUAL brick_format=unorm16 bad_bricks=0 errors=0 bricks=585 JSON_MIN visible_pixels=100)
  sylva_render_test(octree_ooc_store_brick FIXTURE sylva_ooc_store RC 2 ERR "--brick does not apply to a brick store"
    ARGS --volume ${_out}/ml64.store --index octree --brick 32 -o ${_out}/x.png)
endif()
sylva_render_test(octree_ooc_without_octree RC 2 ERR "--frames, --frames-out, --orbit and --feedback need"
  ARGS --volume procedural:ml --frames 4 -o ${_out}/x.png)
sylva_render_test(octree_ooc_budget_too_small RC 1 ERR "holds no brick"
  ARGS --volume procedural:ml --index octree --brick 16 --frames 2 --device-budget 1K -o ${_out}/x.png)
# --index kd and --index octree draw particles into identical images, still and moving (issue 14).
foreach(run still animate)
  add_test(NAME examples.sylva_render.particles_same_image_${run}
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:sylva-render> -DOUT=${_out} -DRUN=${run}
                   -P ${CMAKE_CURRENT_SOURCE_DIR}/particle_index_check.cmake)
  set_tests_properties(examples.sylva_render.particles_same_image_${run} PROPERTIES LABELS "plugins")
endforeach()
sylva_render_test(kd_volume RC 2 ERR "--index kd renders particles"
  ARGS --index kd --volume procedural -o ${_out}/x.png)

# --camera ortho (issue 17) on both backends through the marcher, the kd-tree and the octree (in
# core, and out of core with its cut chosen for the orthographic view), --repeat's median and
# minimum in the stats JSON, the leaf boxes drawn with it; and particles through every index,
# leaf order and exact order, and an animation (their images against the host's and a brute-force
# reference: tests/render/test_particle_rays.cpp).
foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  foreach(pindex bih kd octree)
    foreach(order leaf exact)
      if(pindex STREQUAL "kd" AND order STREQUAL "leaf" AND backend STREQUAL "vulkan")
        continue()  # refused: the kd-tree's leaf order renders on the host only
      endif()
      sylva_render_test(camera_ortho_particles_${pindex}_${order}_${backend} KEYS_ONLY
        ARGS --count 2000 --index ${pindex} --order ${order} --backend ${backend} --camera ortho --size 64x48 --quiet
             -o ${_out}/ortho_p_${pindex}_${order}_${backend}.png --stats-json ${_out}/ortho_p_${pindex}_${order}_${backend}.json
        FILES ${_out}/ortho_p_${pindex}_${order}_${backend}.png JSON ${_out}/ortho_p_${pindex}_${order}_${backend}.json
        EXTRA_KEYS camera
        JSON_EQUAL camera=ortho errors=0 JSON_MIN visible_pixels=100)
    endforeach()
  endforeach()
  # --repeat for particles (the fastest of N frames, index and kernel made once): leaf order and
  # exact order through the BIH.
  foreach(order leaf exact)
    sylva_render_test(particles_repeat_${order}_${backend} KEYS_ONLY
      ARGS --count 2000 --order ${order} --backend ${backend} --repeat 3 --size 64x48 --quiet
           -o ${_out}/repeat_p_${order}_${backend}.png --stats-json ${_out}/repeat_p_${order}_${backend}.json
      FILES ${_out}/repeat_p_${order}_${backend}.png JSON ${_out}/repeat_p_${order}_${backend}.json
      EXTRA_KEYS ms_min ms_median rays_per_s_median frame_ms
      JSON_EQUAL repeat=3 errors=0 JSON_MIN visible_pixels=100 frame_ms.2=0 ms_median=0)
  endforeach()
  sylva_render_test(camera_ortho_animation_${backend} KEYS_ONLY
    ARGS --count 2000 --animate 3 --backend ${backend} --camera ortho --size 64x48 --quiet
         -o ${_out}/ortho_anim_${backend}.png --stats-json ${_out}/ortho_anim_${backend}.json
    FILES ${_out}/ortho_anim_${backend}.png JSON ${_out}/ortho_anim_${backend}.json
    EXTRA_KEYS camera
    JSON_EQUAL camera=ortho errors=0 JSON_MIN visible_pixels=100)
  sylva_render_test(camera_ortho_ooc_${backend} KEYS_ONLY
    ARGS --volume procedural --index octree --frames 4 --backend ${backend} --camera ortho --border clamp --size 64x48
         --quiet -o ${_out}/ortho_ooc_${backend}.png --stats-json ${_out}/ortho_ooc_${backend}.json
    FILES ${_out}/ortho_ooc_${backend}.png JSON ${_out}/ortho_ooc_${backend}.json
    EXTRA_KEYS camera border
    JSON_EQUAL camera=ortho border=clamp errors=0 JSON_MIN visible_pixels=100)
  foreach(index none kd-vidal octree)
    sylva_render_test(camera_ortho_${index}_${backend} KEYS_ONLY
      ARGS --volume procedural --index ${index} --backend ${backend} --camera ortho --repeat 3 --size 64x48 --quiet
           -o ${_out}/ortho_${index}_${backend}.png --stats-json ${_out}/ortho_${index}_${backend}.json
      FILES ${_out}/ortho_${index}_${backend}.png JSON ${_out}/ortho_${index}_${backend}.json
      EXTRA_KEYS ms_min ms_median rays_per_s_median frame_ms camera
      JSON_EQUAL camera=ortho repeat=3 JSON_MIN visible_pixels=100 frame_ms.2=0 ms_median=0)
  endforeach()
endforeach()
# The kd-tree's leaf boxes drawn with the orthographic camera (--boxes; the projection itself is
# tested against the cameras' rays by unit.test_render_boxes).
sylva_render_test(camera_ortho_boxes KEYS_ONLY
  ARGS --volume procedural --index kd-vidal --camera ortho --size 64x48 --quiet -o ${_out}/ortho_boxes.png
       --boxes ${_out}/ortho_boxes_lines.png --stats-json ${_out}/ortho_boxes.json
  FILES ${_out}/ortho_boxes.png ${_out}/ortho_boxes_lines.png JSON ${_out}/ortho_boxes.json
  JSON_EQUAL camera=ortho EXTRA_KEYS camera)
# --grid native|sparse (issue 17): the uint8 aneurism from 1 byte a voxel (grid_bytes = the voxel
# count) and from 8^3 bricks with the uniform ones held in the brick table (7,041 of 32,768
# bricks stored: 3,736,064 bytes), through the ESS kd-tree on both backends. That the images are
# the dense grid's, bit for bit, is checked by test_grid (host) and test_grid_vulkan (lavapipe).
foreach(backend cpu vulkan)
  if(backend STREQUAL "vulkan" AND NOT SYLVA_WITH_VULKAN)
    continue()
  endif()
  foreach(grid native sparse)
    if(grid STREQUAL "native")
      set(_grid_json grid_bytes=16777216 grid_format=uint8)
    else()
      set(_grid_json grid_bytes=3736064 grid_format=sparse-uint8)
    endif()
    sylva_render_test(grid_${grid}_aneurism_${backend} NEED ${_data}/aneurism_256x256x256_uint8.raw
      ARGS --volume ${_data}/aneurism_256x256x256_uint8.raw --index kd-vidal --backend ${backend} --grid ${grid}
           --size 64x48 --quiet -o ${_out}/grid_${grid}_${backend}.png --stats-json ${_out}/grid_${grid}_${backend}.json
      FILES ${_out}/grid_${grid}_${backend}.png JSON ${_out}/grid_${grid}_${backend}.json
      EXTRA_KEYS grid_bytes grid_format index_bytes
      JSON_EQUAL ${_grid_json} voxels=16777216 errors=0 JSON_MIN visible_pixels=100)
  endforeach()
endforeach()

# The command line through CLI11 and the stats JSON through nlohmann-json (issue 16, item 6):
# --help (and -h after bad options) exits 0 listing every option registered in options.cpp;
# bad usage exits 2 with a message naming the option and a hint; numbers in e-notation; an option
# given twice takes the last value; the stats JSON parses with string(JSON) and has every key of
# particle, volume and out-of-core runs with its JSON type.
add_test(NAME examples.sylva_render.cli_help
         COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:sylva-render>
                 -DSOURCE=${CMAKE_CURRENT_SOURCE_DIR}/sylva_render/options.cpp
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/render_help_check.cmake)
sylva_render_test(cli_stray_argument RC 2 ERR "unknown option 'frame\\.png'" ARGS frame.png -o ${_out}/x.png)
sylva_render_test(cli_missing_value RC 2 ERR "--index needs a value" ARGS -o ${_out}/x.png --index)
sylva_render_test(cli_threads_out_of_range RC 2
  ERR "sylva-render: --threads: '2000' is not a number in \\[0, 1024\\].Run sylva-render --help for the options"
  ARGS --threads 2000 -o ${_out}/x.png)
sylva_render_test(cli_count_out_of_range RC 2 ERR "--count: '2e8' is not a number in \\[1, 100000000\\]"
  ARGS --count 2e8 -o ${_out}/x.png)
sylva_render_test(cli_size_out_of_range RC 2 ERR "--size: '0' is not a number in \\[1, 16384\\]"
  ARGS --size 0x16 -o ${_out}/x.png)
sylva_render_test(cli_size_not_wxh RC 2 ERR "--size: '64' is not WxH" ARGS --size 64 -o ${_out}/x.png)
sylva_render_test(cli_view_not_xyz RC 2 ERR "--view: '1,2' is not X,Y,Z" ARGS --view 1,2 -o ${_out}/x.png)
sylva_render_test(cli_budget_not_a_size RC 2 ERR "--memory-budget: '12Q' is not a number"
  ARGS --volume procedural:ml --index octree --memory-budget 12Q -o ${_out}/x.png)
sylva_render_test(cli_iso_cull_word RC 2 ERR "--iso-cull: 'maybe' is not one of on\\|off"
  ARGS --index implicit-kd --iso-cull maybe -o ${_out}/x.png)
set(_stats_keys index backend device input elements nodes leaves max_depth single_child_percent bytes build_ms
    encode_ms render_ms rays_per_s width height repeat ms_min ms_median rays_per_s_median frame_ms camera steps_mean
    steps_max visible_pixels errors)
set(_stats_types index=STRING backend=STRING device=STRING input=STRING camera=STRING frame_ms=ARRAY
    elements=NUMBER render_ms=NUMBER rays_per_s_median=NUMBER visible_pixels=NUMBER errors=NUMBER)
sylva_render_test(stats_json_particles
  ARGS --count 1e3 --count 2e3 --size 8x8 --size 48x36 --view -1,0.5,1 --quiet -o ${_out}/stats_particles.png
       --stats-json ${_out}/stats_particles.json
  FILES ${_out}/stats_particles.png JSON ${_out}/stats_particles.json EXTRA_KEYS ${_stats_keys} order
  JSON_EQUAL elements=2000 width=48 height=36 order=exact backend=cpu errors=0 JSON_MIN visible_pixels=1
  JSON_TYPE ${_stats_types} order=STRING)
sylva_render_test(stats_json_volume
  ARGS --mode dvr --steps 64 --size 48x36 --quiet -o ${_out}/stats_volume.png --stats-json ${_out}/stats_volume.json
  FILES ${_out}/stats_volume.png JSON ${_out}/stats_volume.json
  EXTRA_KEYS ${_stats_keys} mode value_range value_range_source data_bytes voxels grid_bytes index_bytes grid_format
             border grid_bytes_16bit full_nodes full_single_child_percent full_max_depth full_bytes full_bytes_paper
             full_ms lod_nodes lod_leaves lod_max_depth lod_bytes lod_ms
  JSON_EQUAL value_range.0=0 value_range.1=1 "value_range_source=procedural densities" errors=0
  JSON_TYPE ${_stats_types} mode=STRING value_range=ARRAY value_range.1=NUMBER grid_format=STRING full_ms=NUMBER)
sylva_render_test(stats_json_ooc
  ARGS --volume procedural:ml --index octree --brick 16 --frames 2 --memory-budget 8M --device-budget 4M --size 48x36
       --quiet -o ${_out}/stats_ooc.png --stats-json ${_out}/stats_ooc.json
  FILES ${_out}/stats_ooc.png JSON ${_out}/stats_ooc.json EXTRA_KEYS ${_stats_keys} ${_oct_keys} ${_ooc_keys}
  JSON_EQUAL memory_budget=8388608 device_budget=4194304 bad_bricks=0 feedback=ON
  JSON_TYPE ${_stats_types} feedback=BOOLEAN frames=ARRAY frames.1=OBJECT frames.1.cut_nodes=NUMBER
            lod_pixels=NUMBER index_bytes=NUMBER)

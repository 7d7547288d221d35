# Extra ctest entries for the shells area (included from tests/CMakeLists.txt): the
# moon07_shell_transport example at a reduced path count (~3 s) and its bad-argument handling.
if(TARGET moon07_shell_transport OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/moon07_shell_transport.cpp))
  set(_m7 $<TARGET_FILE:moon07_shell_transport>)
  set(_m7out ${CMAKE_CURRENT_BINARY_DIR}/moon07_out)
  # Shell stepping with a table from 5000 explicit glass-sphere paths reproduces the explicit
  # mean-square displacement of chained r = 8 R spheres within 5 % (measured: 1.2 %), and the
  # NMF (rank 5) reconstructs the k-NN density within 10 % (measured: 4.5 %); the Fig. 6 shadow-ray
  # estimate of the light reaching a small cone light agrees with counting hits.
  add_test(NAME moon07_shell_transport_json
           COMMAND ${CMAKE_COMMAND} -DEXE=${_m7} "-DARGS=--paths;5000;--threads;2;--out;${_m7out}"
                   "-DCHECKS=max_msd_rel_diff <= 0.05;nmf_error <= 0.1;msd_explicit_last > 64;abs(direct_hits - direct_nee) <= 4 * (direct_hits_se + direct_nee_se)"
                   -DEXPECT_FILE=${_m7out}/moon07_shells.shel
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  add_test(NAME moon07_shell_transport_bad_fraction COMMAND ${_m7} --fraction 0.5 --out ${_m7out})
  set_tests_properties(moon07_shell_transport_bad_fraction PROPERTIES PASS_REGULAR_EXPRESSION "fraction")
  set_tests_properties(moon07_shell_transport_json moon07_shell_transport_bad_fraction
                       PROPERTIES LABELS "example;shells")
endif()

# slab --method shells (Moon07 shells built from the slab's own continuous medium, shell stepping
# in the interior, exact steps within r0 of a face) against slab --method vpt (the exact walk):
# within 3 % + 0.005 in R and T on thick slabs (issue 10). Reference values: slab --method vpt
# --paths 4000000 --seed 11 (standard errors 0.00025); each entry builds a table from 50 000
# paths (~5-10 s) and runs 200 000 slab photons.
if(TARGET slab OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/slab.cpp))
  set(_slab $<TARGET_FILE:slab>)
  set(_shell_args "--method;shells;--shell-paths;50000;--paths;200000;--threads;2;--seed;3")
  function(_m7_slab name args r_ref t_ref)
    add_test(NAME ${name}
             COMMAND ${CMAKE_COMMAND} -DEXE=${_slab} "-DARGS=${args};${_shell_args}"
                     "-DCHECKS=abs(R - ${r_ref}) <= 0.03 * ${r_ref} + 0.005;abs(T - ${t_ref}) <= 0.03 * ${t_ref} + 0.005;shell_steps_per_path > 0.5;shell_build_seconds > 0"
                     -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
    set_tests_properties(${name} PROPERTIES LABELS "example;shells")
  endfunction()
  _m7_slab(slab_shells_b4_a09_g0 "--albedo;0.9;--optical-depth;4;--g;0" 0.40783 0.12850)
  _m7_slab(slab_shells_b4_a099_g05 "--albedo;0.99;--optical-depth;4;--g;0.5" 0.46982 0.45273)
  _m7_slab(slab_shells_inf_a099_g05 "--albedo;0.99;--optical-depth;inf;--g;0.5" 0.66489 0)
  _m7_slab(slab_shells_inf_a095_g0 "--albedo;0.95;--optical-depth;inf;--g;0" 0.53551 0)
  # No shell fits between the faces of a thin slab: the error names the optical depth.
  add_test(NAME slab_shells_no_shell_fits COMMAND ${_slab} --method shells --optical-depth 1 --paths 100)
  set_tests_properties(slab_shells_no_shell_fits PROPERTIES PASS_REGULAR_EXPRESSION "optical_depth = 1"
                       LABELS "example;shells")
  add_test(NAME slab_bad_method COMMAND ${_slab} --method shell --paths 100)
  set_tests_properties(slab_bad_method PROPERTIES PASS_REGULAR_EXPRESSION "method" LABELS "example;shells")
endif()

# moon07_fig9_cube_shadow at a reduced size (4000 spheres, 40 x 30 pixels, ~10 s): the JSON has
# every key issue 10 names (the equal-error speed-up is printed, not asserted: it is a timing), and
# its mean over the cube agrees with the path-traced reference within 4 standard errors + 10 %
# (the exit rule's bias; measured at quick: +3 +- 5 %).
if(TARGET moon07_fig9_cube_shadow OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/moon07_fig9_cube_shadow.cpp))
  set(_f9 $<TARGET_FILE:moon07_fig9_cube_shadow>)
  set(_f9out ${CMAKE_CURRENT_BINARY_DIR}/moon07_fig9_out)
  add_test(NAME moon07_fig9_cube_shadow_json
           COMMAND ${CMAKE_COMMAND} -DEXE=${_f9}
                   "-DARGS=--spheres;4000;--width;40;--spp-pt;96;--spp-low;16;--spp-high;16;--shell-paths;8000;--threads;2;--rebuild-table;--out;${_f9out}"
                   "-DCHECKS=seconds_pt > 0;seconds_low > 0;seconds_high > 0;rmse_pt > 0;rmse_shells > 0;speedup_equal_error > 0;mean_pt > 0;mean_shells > 0;abs(mean_shells - mean_pt) <= 4 * bias_rel_se * mean_pt + 0.1 * mean_pt;shell_factored_bytes < shell_raw_bytes"
                   -DEXPECT_FILE=${_f9out}/moon07_fig9_shells.exr
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  add_test(NAME moon07_fig9_cube_shadow_bad_fraction COMMAND ${_f9} --fraction 0.5 --out ${_f9out})
  set_tests_properties(moon07_fig9_cube_shadow_bad_fraction PROPERTIES PASS_REGULAR_EXPRESSION "fraction")
  set_tests_properties(moon07_fig9_cube_shadow_json moon07_fig9_cube_shadow_bad_fraction
                       PROPERTIES LABELS "example;shells")
endif()

# moon07_fig11_spotlight at a reduced size (4000 spheres, 40 x 30 pixels): every key of issue 10
# and the spot fractions are in the JSON (the equal-error speed-up is printed, not asserted), the
# mean agrees with the path-traced reference within 4 standard errors + 5 %.
if(TARGET moon07_fig11_spotlight OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/moon07_fig11_spotlight.cpp))
  set(_f11 $<TARGET_FILE:moon07_fig11_spotlight>)
  set(_f11out ${CMAKE_CURRENT_BINARY_DIR}/moon07_fig11_out)
  add_test(NAME moon07_fig11_spotlight_json
           COMMAND ${CMAKE_COMMAND} -DEXE=${_f11}
                   "-DARGS=--spheres;4000;--width;40;--spp-pt;96;--spp-low;16;--spp-high;16;--shell-paths;8000;--threads;2;--rebuild-table;--out;${_f11out}"
                   "-DCHECKS=seconds_pt > 0;seconds_low > 0;seconds_high > 0;rmse_pt > 0;rmse_shells > 0;speedup_equal_error > 0;mean_pt > 0;mean_shells > 0;abs(mean_shells - mean_pt) <= 4 * bias_rel_se * mean_pt + 0.05 * mean_pt;spot_fraction_pt >= 0;spot_fraction_shells > 0;spot_fraction_shells < 1;exit_rule_bias > -1"
                   -DEXPECT_FILE=${_f11out}/moon07_fig11_shells.exr
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  # An MD packing at f = 0.6 (poured beads) seen from 44 deg above the horizon (docs/moon07.md: the
  # spot fraction is set by the view; 61-68 % there at quick against 11-15 % from the default 18 deg).
  add_test(NAME moon07_fig11_spotlight_md_view
           COMMAND ${CMAKE_COMMAND} -DEXE=${_f11}
                   "-DARGS=--spheres;4000;--packing;md;--fraction;0.6;--camera-height;3;--width;40;--spp-pt;96;--spp-low;16;--spp-high;16;--shell-paths;8000;--threads;2;--rebuild-table;--out;${_f11out}_md"
                   "-DCHECKS=packing_fraction > 0.59;camera_height == 3;abs(mean_shells - mean_pt) <= 4 * bias_rel_se * mean_pt + 0.05 * mean_pt;spot_fraction_pt > 0.3;spot_fraction_shells > 0.3;abs(spot_fraction_shells - spot_fraction_pt) < 0.1"
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  add_test(NAME moon07_fig11_spotlight_bad_packing COMMAND ${_f11} --packing poisson --out ${_f11out})
  set_tests_properties(moon07_fig11_spotlight_bad_packing PROPERTIES PASS_REGULAR_EXPRESSION "packing")
  set_tests_properties(moon07_fig11_spotlight_md_view moon07_fig11_spotlight_bad_packing PROPERTIES LABELS "example;shells")
  add_test(NAME moon07_fig11_spotlight_bad_angle COMMAND ${_f11} --spot-angle 90 --out ${_f11out})
  set_tests_properties(moon07_fig11_spotlight_bad_angle PROPERTIES PASS_REGULAR_EXPRESSION "spot-angle")
  set_tests_properties(moon07_fig11_spotlight_json moon07_fig11_spotlight_bad_angle
                       PROPERTIES LABELS "example;shells")
endif()

# Resumable renders (hardening issue item 6): each Moon07 scene example killed with SIGKILL once three of
# its per-batch checkpoints exist (--checkpoint 0), resumed with --resume, writes the same four
# images byte for byte as an uninterrupted run and leaves no checkpoint behind (~3 s each).
foreach(_m7kr moon07_fig9_cube_shadow:fig9 moon07_fig11_spotlight:fig11 moon07_fig12_bowl:fig12)
  string(REPLACE ":" ";" _m7kr_l ${_m7kr})
  list(GET _m7kr_l 0 _m7kr_exe)
  list(GET _m7kr_l 1 _m7kr_tag)
  if(TARGET ${_m7kr_exe} OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/${_m7kr_exe}.cpp))
    add_test(NAME ${_m7kr_exe}_kill_resume
             COMMAND bash ${PROJECT_SOURCE_DIR}/tests/common/kill_resume.sh $<TARGET_FILE:${_m7kr_exe}>
                     ${CMAKE_CURRENT_BINARY_DIR}/kill_resume_${_m7kr_tag}
                     "moon07_${_m7kr_tag}_pt.exr moon07_${_m7kr_tag}_low.exr moon07_${_m7kr_tag}_high.exr moon07_${_m7kr_tag}_shells.exr"
                     --spheres 2000 --width 24 --spp-pt 16 --spp-low 8 --spp-high 8 --shell-paths 4000 --batches 4
                     --threads 2 --seed 2)
    set_tests_properties(${_m7kr_exe}_kill_resume PROPERTIES LABELS "example;shells;checkpoint" TIMEOUT 300
      PASS_REGULAR_EXPRESSION "byte-identical")
  endif()
endforeach()

# moon07_fig12_bowl at --quality quick (8000 spheres in the bowl, 128 x 96, ~30 s wall on 2
# threads): every key of issue 10, a compressed shell table, and the mean over the bowl within 4
# standard errors + 5 % of the path-traced reference (measured: +5.1 +- 2.9 % with the tracer's
# continuation hook, table light kept; -4.7 +- 2.9 % with --no-continuation).
if(TARGET moon07_fig12_bowl OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/moon07_fig12_bowl.cpp))
  set(_f12 $<TARGET_FILE:moon07_fig12_bowl>)
  set(_f12out ${CMAKE_CURRENT_BINARY_DIR}/moon07_fig12_out)
  add_test(NAME moon07_fig12_bowl_json
           COMMAND ${CMAKE_COMMAND} -DEXE=${_f12}
                   "-DARGS=--quality;quick;--threads;2;--rebuild-table;--out;${_f12out}"
                   "-DCHECKS=seconds_pt > 0;seconds_low > 0;seconds_high > 0;rmse_pt > 0;rmse_shells > 0;speedup_equal_error > 0;mean_pt > 0;mean_shells > 0;abs(mean_shells - mean_pt) <= 4 * bias_rel_se * mean_pt + 0.05 * mean_pt;exit_rule_bias > -1;shell_factored_bytes < shell_raw_bytes;bowl_pixels > 100"
                   -DEXPECT_FILE=${_f12out}/moon07_fig12_shells.exr
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  add_test(NAME moon07_fig12_bowl_bad_albedo COMMAND ${_f12} --table-albedo 1.5 --out ${_f12out})
  set_tests_properties(moon07_fig12_bowl_bad_albedo PROPERTIES PASS_REGULAR_EXPRESSION "table-albedo")
  set_tests_properties(moon07_fig12_bowl_json moon07_fig12_bowl_bad_albedo PROPERTIES LABELS "example;shells")
endif()

# moon07_fig2_retroreflection at --quality quick (200 000 rays per case, ~12 CPU s): every key,
# and the independent physical statement of Moon07 Fig. 2: the closely packed scatterers' excess
# back-scatter over the volumetric prediction (same mean free path, single-scatterer phase
# function) exceeds the small sparse scatterers' by more than 3 standard errors, in 2D and in 3D
# (measured at quick: 2D 1.34 +- 0.03 vs 1.05 +- 0.02, 3D 1.34 +- 0.07 vs 1.08 +- 0.06), and the
# sparse case follows the volumetric prediction (scattered fraction within 0.03).
if(TARGET moon07_fig2_retroreflection OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/moon07_fig2_retroreflection.cpp))
  set(_f2 $<TARGET_FILE:moon07_fig2_retroreflection>)
  set(_f2out ${CMAKE_CURRENT_BINARY_DIR}/moon07_fig2_out)
  add_test(NAME moon07_fig2_retroreflection_json
           COMMAND ${CMAKE_COMMAND} -DEXE=${_f2}
                   "-DARGS=--quality;quick;--threads;2;--out;${_f2out}"
                   "-DCHECKS=peak_ratio_2d_sparse > 0;peak_ratio_2d_packed > 0;peak_ratio_3d_sparse > 0;peak_ratio_3d_packed > 0;back_excess_2d_packed - back_excess_2d_sparse > 3 * sqrt(peak_ratio_2d_packed_se * peak_ratio_2d_packed_se + peak_ratio_2d_sparse_se * peak_ratio_2d_sparse_se);back_excess_3d_packed - back_excess_3d_sparse > 3 * sqrt(peak_ratio_3d_packed_se * peak_ratio_3d_packed_se + peak_ratio_3d_sparse_se * peak_ratio_3d_sparse_se);abs(scattered_2d_sparse - scattered_volumetric_2d_sparse) < 0.03;abs(scattered_3d_sparse - scattered_volumetric_3d_sparse) < 0.03;mean_free_path_3d_packed > 0"
                   -DEXPECT_FILE=${_f2out}/moon07_fig2.csv
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  add_test(NAME moon07_fig2_retroreflection_bad_window COMMAND ${_f2} --back-window 90 --out ${_f2out})
  set_tests_properties(moon07_fig2_retroreflection_bad_window PROPERTIES PASS_REGULAR_EXPRESSION "back-window")
  set_tests_properties(moon07_fig2_retroreflection_json moon07_fig2_retroreflection_bad_window
                       PROPERTIES LABELS "example;shells")
endif()

# moon07_fig13_grains at --quality quick (3000 procedural grain meshes in a bowl, 64 x 48, ~15 CPU
# s): every key of issue 10, shells built from the grain aggregate (compressed), and the mean over
# the bowl within 4 standard errors + 10 % of the EPT reference (measured: -5.2 +- 6.5 %).
if(TARGET moon07_fig13_grains OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/moon07_fig13_grains.cpp))
  set(_f13 $<TARGET_FILE:moon07_fig13_grains>)
  set(_f13out ${CMAKE_CURRENT_BINARY_DIR}/moon07_fig13_out)
  add_test(NAME moon07_fig13_grains_json
           COMMAND ${CMAKE_COMMAND} -DEXE=${_f13}
                   "-DARGS=--quality;quick;--threads;2;--rebuild-table;--out;${_f13out}"
                   "-DCHECKS=seconds_pt > 0;seconds_low > 0;seconds_high > 0;rmse_pt > 0;rmse_shells > 0;speedup_equal_error > 0;mean_pt > 0;mean_shells > 0;mean_high > 0;abs(mean_shells - mean_pt) <= 4 * bias_rel_se * mean_pt + 0.1 * mean_pt;shell_factored_bytes < shell_raw_bytes;grains > 2000;exemplars == 2;switched_fraction > 0"
                   -DEXPECT_FILE=${_f13out}/moon07_fig13_shells.exr
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  add_test(NAME moon07_fig13_grains_bad_preset COMMAND ${_f13} --presets flour --out ${_f13out})
  set_tests_properties(moon07_fig13_grains_bad_preset PROPERTIES PASS_REGULAR_EXPRESSION "presets")
  set_tests_properties(moon07_fig13_grains_json moon07_fig13_grains_bad_preset PROPERTIES LABELS "example;shells")
endif()

# MPI scale-out of the Moon07 renders (issue 14): moon07_fig9_cube_shadow with 2 ranks (each
# renders the rows y % 2 == rank of every batch of the three passes, gathered on rank 0) writes
# the shells image byte-identical to one process and reports "ranks": 2 (a small scene, ~10 s).
if(TARGET MPI::MPI_CXX AND MPIEXEC_EXECUTABLE AND (TARGET moon07_fig9_cube_shadow OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/moon07_fig9_cube_shadow.cpp)))
  add_test(NAME moon07_fig9_cube_shadow_mpi
           COMMAND bash ${PROJECT_SOURCE_DIR}/tests/common/mpi_compare.sh ${MPIEXEC_EXECUTABLE} 2
                   ${CMAKE_CURRENT_BINARY_DIR}/mpi_fig9_work moon07_fig9_shells.exr $<TARGET_FILE:moon07_fig9_cube_shadow>
                   --spheres 2000 --width 32 --spp-pt 16 --spp-low 8 --spp-high 8 --batches 4 --shell-paths 4000 --seed 1)
  set_tests_properties(moon07_fig9_cube_shadow_mpi PROPERTIES LABELS "example;shells;mpi" TIMEOUT 300
    PASS_REGULAR_EXPRESSION "byte-identical to one process")
endif()

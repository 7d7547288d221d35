# Extra ctest entries for the precompute area (included from tests/CMakeLists.txt): the
# grain_stats example's bad-input handling and its JSON line against analytic values.
if(TARGET grain_stats OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/grain_stats.cpp))
  set(_gs $<TARGET_FILE:grain_stats>)
  set(_out ${CMAKE_CURRENT_BINARY_DIR}/grain_stats_out)
  foreach(r 0 -1 1.5)
    add_test(NAME grain_stats_bad_radius_${r}
             COMMAND ${_gs} --shape sphere --material dielectric --grain-radius ${r} --rays 100 --out ${_out})
    set_tests_properties(grain_stats_bad_radius_${r} PROPERTIES PASS_REGULAR_EXPRESSION "radius = ${r}"
                         LABELS "example;precompute")
  endforeach()
  add_test(NAME grain_stats_bad_shape COMMAND ${_gs} --shape potato --material dielectric --grain-radius 1 --out ${_out})
  set_tests_properties(grain_stats_bad_shape PROPERTIES WILL_FAIL TRUE LABELS "example;precompute")
  add_test(NAME grain_stats_bad_preset COMMAND ${_gs} --preset gravel --out ${_out})
  set_tests_properties(grain_stats_bad_preset PROPERTIES WILL_FAIL TRUE LABELS "example;precompute")
  # Glass beads (Meng15 Table 1: beta 1.00, lambda_delta 0.00, alpha_s 1.00); lambda_s = 1.424
  # for ior 1.5 from the deterministic Fresnel series of test_scatterometer.cpp.
  add_test(NAME grain_stats_json_glass_bead
           COMMAND ${CMAKE_COMMAND} -DEXE=${_gs} "-DARGS=--preset;glass-bead;--rays;100000;--seed;3;--out;${_out}"
                   "-DCHECKS=abs(beta - 1) <= 0.0001;abs(lambda_delta - 0) <= 0.0001;abs(alpha_s - 1) <= 0.0001;abs(lambda_s - 1.424) <= 0.01"
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  # Dielectric sphere of radius 0.5: beta = rho^2 = 0.25, lambda_delta = (4/3) sqrt(1 - rho^2) = 1.1547.
  add_test(NAME grain_stats_json_small_sphere
           COMMAND ${CMAKE_COMMAND} -DEXE=${_gs}
                   "-DARGS=--shape;sphere;--material;dielectric;--ior;1.33;--grain-radius;0.5;--rays;100000;--seed;4;--out;${_out}"
                   "-DCHECKS=abs(beta - 0.25) <= 0.006;abs(lambda_delta - 1.1547) <= 0.005;abs(alpha_s - 1) <= 0.0001"
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  # Diffuse sphere filling its bounding sphere: alpha_s = albedo, lambda_s = 0, g = -4/9.
  add_test(NAME grain_stats_json_diffuse_sphere
           COMMAND ${CMAKE_COMMAND} -DEXE=${_gs}
                   "-DARGS=--shape;sphere;--material;diffuse;--albedo;0.7;--grain-radius;1;--rays;100000;--seed;5;--out;${_out}"
                   "-DCHECKS=abs(beta - 1) <= 0.0001;abs(alpha_s - 0.7) <= 0.01;abs(lambda_s - 0) <= 0.0001;abs(g - -0.4444) <= 0.01"
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  set_tests_properties(grain_stats_json_glass_bead grain_stats_json_small_sphere grain_stats_json_diffuse_sphere
                       PROPERTIES LABELS "example;precompute")
endif()
# grain_stats --load: truncated and corrupted scatterometer files (tests/data/grains_*.scat are the
# first 200 bytes of a real file, the second with one header byte flipped) and bad mixing weights.
if(TARGET grain_stats OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/grain_stats.cpp))
  add_test(NAME grain_stats_truncated_file
           COMMAND $<TARGET_FILE:grain_stats> --load ${CMAKE_CURRENT_SOURCE_DIR}/data/grains_truncated.scat
                   --out ${CMAKE_CURRENT_BINARY_DIR}/grain_stats_out)
  set_tests_properties(grain_stats_truncated_file PROPERTIES PASS_REGULAR_EXPRESSION "truncated" LABELS "example;precompute")
  add_test(NAME grain_stats_corrupted_file
           COMMAND $<TARGET_FILE:grain_stats> --load ${CMAKE_CURRENT_SOURCE_DIR}/data/grains_corrupt_header.scat
                   --out ${CMAKE_CURRENT_BINARY_DIR}/grain_stats_out)
  set_tests_properties(grain_stats_corrupted_file PROPERTIES PASS_REGULAR_EXPRESSION "corrupted header"
                       LABELS "example;precompute")
  add_test(NAME grain_stats_zero_weights
           COMMAND $<TARGET_FILE:grain_stats> --preset salt,flour --weights 0,0 --rays 100
                   --out ${CMAKE_CURRENT_BINARY_DIR}/grain_stats_out)
  set_tests_properties(grain_stats_zero_weights PROPERTIES PASS_REGULAR_EXPRESSION "sum of weights = 0"
                       LABELS "example;precompute")
  add_test(NAME grain_stats_negative_weight
           COMMAND $<TARGET_FILE:grain_stats> --preset salt,flour --weights 1,-0.5 --rays 100
                   --out ${CMAKE_CURRENT_BINARY_DIR}/grain_stats_out)
  set_tests_properties(grain_stats_negative_weight PROPERTIES PASS_REGULAR_EXPRESSION "weights\\[1\\] = -0.5"
                       LABELS "example;precompute")
endif()

# MPI scale-out of a precomputation (ecosystem issue): the scatterometer's ray blocks over 3
# ranks (more ranks than cores: --oversubscribe) give the single-process statistics file byte for byte.
if(TARGET MPI::MPI_CXX AND MPIEXEC_EXECUTABLE AND GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/grain_stats.cpp)
  add_test(NAME grain_stats_mpi
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/common/mpi_compare.sh ${MPIEXEC_EXECUTABLE} 3
                   ${CMAKE_CURRENT_BINARY_DIR}/mpi_grain_stats_work grain_stats_snow.scat $<TARGET_FILE:grain_stats>
                   --preset snow --rays 100000 --seed 4)
  set_tests_properties(grain_stats_mpi PROPERTIES LABELS "example;precompute;mpi" TIMEOUT 300
    PASS_REGULAR_EXPRESSION "byte-identical to one process")
endif()

# ms_table (Wang18's multiple-scattering table as a precomputation): in an infinite medium orders
# >= 2 emit alpha^2 / (1 - alpha) per unit scattered power (closed form); a +-10 mfp box captures
# all but a few tenths of a percent of it for alpha <= 0.7 (MC error ~1 % at 20000 particles).
if(TARGET ms_table OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/ms_table.cpp))
  add_test(NAME ms_table_json
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:ms_table>
                   "-DARGS=--albedo;0.3,0.5,0.7;--g;0.5;--photons;20000;--n-rho;16;--n-z;32;--n-theta;8;--n-phi;4;--seed;2;--out;${CMAKE_CURRENT_BINARY_DIR}/ms_table_out"
                   "-DCHECKS=abs(captured_min - 1) <= 0.03;abs(captured_max - 1) <= 0.03;table_mb > 0"
                   -DEXPECT_FILE=${CMAKE_CURRENT_BINARY_DIR}/ms_table_out/ms_table.mstab
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  add_test(NAME ms_table_bad_albedo COMMAND $<TARGET_FILE:ms_table> --albedo 1.0 --out ${CMAKE_CURRENT_BINARY_DIR}/ms_table_out)
  set_tests_properties(ms_table_bad_albedo PROPERTIES PASS_REGULAR_EXPRESSION "albedo = 1.0+ must be in \\[0, 1\\)")
  set_tests_properties(ms_table_json ms_table_bad_albedo PROPERTIES LABELS "example;precompute;point_based")
endif()
# The same table built by 2 MPI ranks (block ranges appended in order) is the single-process file byte for byte.
if(TARGET MPI::MPI_CXX AND MPIEXEC_EXECUTABLE AND GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/ms_table.cpp)
  add_test(NAME ms_table_mpi
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/common/mpi_compare.sh ${MPIEXEC_EXECUTABLE} 2
                   ${CMAKE_CURRENT_BINARY_DIR}/mpi_ms_table_work ms_table.mstab $<TARGET_FILE:ms_table>
                   --photons 20000 --n-rho 16 --n-z 32 --n-theta 8 --n-phi 4 --blocks 7 --seed 3)
  set_tests_properties(ms_table_mpi PROPERTIES LABELS "example;precompute;mpi" TIMEOUT 300
    PASS_REGULAR_EXPRESSION "byte-identical to one process")
endif()
# The Moon07 shell table of `slab --method shells` sampled by 2 MPI ranks (path-block ranges merged
# in order) is the single-process table file byte for byte.
if(TARGET MPI::MPI_CXX AND MPIEXEC_EXECUTABLE AND GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/slab.cpp)
  add_test(NAME slab_shells_mpi
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/common/mpi_compare.sh ${MPIEXEC_EXECUTABLE} 2
                   ${CMAKE_CURRENT_BINARY_DIR}/mpi_slab_shells_work slab_shells.shel $<TARGET_FILE:slab>
                   --method shells --albedo 0.95 --optical-depth 4 --g 0.3 --paths 20000 --shell-paths 20000
                   --shell-radii 6 --shell-grid 12,8,8 --seed 2)
  set_tests_properties(slab_shells_mpi PROPERTIES LABELS "example;precompute;shells;mpi" TIMEOUT 300
    PASS_REGULAR_EXPRESSION "byte-identical to one process")
endif()

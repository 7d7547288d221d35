# Extra ctest entries for the integrators area (included from tests/CMakeLists.txt).
# They run the `slab` example: bad arguments must fail with a message naming the argument, and a
# quick run's JSON line must match the adding-doubling reference (halfspace_albedo.md) within
# 3 standard errors + 0.002.
# tests/ is added before examples/, so `if(TARGET slab)` would be false here: test for the
# example's source instead ($<TARGET_FILE:slab> resolves at generate time, in any order).
if(TARGET slab OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/slab.cpp))
  add_test(NAME slab_bad_albedo COMMAND $<TARGET_FILE:slab> --albedo 1.5 --optical-depth 1 --paths 100)
  set_tests_properties(slab_bad_albedo PROPERTIES WILL_FAIL TRUE LABELS "example;integrators")
  add_test(NAME slab_bad_albedo_message COMMAND $<TARGET_FILE:slab> --albedo 1.5 --optical-depth 1 --paths 100)
  set_tests_properties(slab_bad_albedo_message PROPERTIES PASS_REGULAR_EXPRESSION "albedo = 1.5"
                       LABELS "example;integrators")
  add_test(NAME slab_bad_optical_depth COMMAND $<TARGET_FILE:slab> --optical-depth abc)
  set_tests_properties(slab_bad_optical_depth PROPERTIES WILL_FAIL TRUE LABELS "example;integrators")
  add_test(NAME slab_unknown_argument COMMAND $<TARGET_FILE:slab> --albedoo 0.5)
  set_tests_properties(slab_unknown_argument PROPERTIES WILL_FAIL TRUE LABELS "example;integrators")
  # Index-matched, g = 0, a = 0.9, b = 1, mu0 = 1: Prahl AD R = 0.26741, T = 0.59163.
  add_test(NAME slab_json_index_matched
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:slab>
                   "-DARGS=--albedo;0.9;--optical-depth;1;--g;0;--ior;1;--mu0;1;--paths;400000;--seed;5"
                   "-DCHECKS=abs(R - 0.26741) <= 3 * R_stderr + 0.002;abs(T - 0.59163) <= 3 * T_stderr + 0.002;paths == 400000"
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  # n = 1.4, g = 0.8, a = 0.95, b = 1: Prahl AD R = 0.10840, T = 0.78517.
  add_test(NAME slab_json_refractive
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:slab>
                   "-DARGS=--albedo;0.95;--optical-depth;1;--g;0.8;--ior;1.4;--mu0;1;--paths;400000;--seed;6"
                   "-DCHECKS=abs(R - 0.10840) <= 3 * R_stderr + 0.002;abs(T - 0.78517) <= 3 * T_stderr + 0.002"
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  set_tests_properties(slab_json_index_matched slab_json_refractive PROPERTIES LABELS "example;integrators")
endif()

# The rendered example: a tiny run must write the EXR and PNG and print its JSON line; a bad
# --quality must exit non-zero with a message naming the argument.
if(TARGET vpt_sphere_medium OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/vpt_sphere_medium.cpp))
  add_test(NAME vpt_sphere_medium_tiny
           COMMAND $<TARGET_FILE:vpt_sphere_medium> --spp 1 --threads 2 --out ${CMAKE_CURRENT_BINARY_DIR}/vpt_sphere_medium_tiny)
  set_tests_properties(vpt_sphere_medium_tiny PROPERTIES
                       PASS_REGULAR_EXPRESSION "\"mean_rgb\":\\[0\\.[0-9]+,0\\.[0-9]+,0\\.[0-9]+\\].*vpt_sphere_medium\\.png"
                       LABELS "example;integrators")
  add_test(NAME vpt_sphere_medium_bad_quality COMMAND $<TARGET_FILE:vpt_sphere_medium> --quality fast --spp 1)
  set_tests_properties(vpt_sphere_medium_bad_quality PROPERTIES PASS_REGULAR_EXPRESSION "--quality = 'fast'"
                       LABELS "example;integrators")
  add_test(NAME vpt_sphere_medium_bad_quality_exit COMMAND $<TARGET_FILE:vpt_sphere_medium> --quality fast --spp 1)
  set_tests_properties(vpt_sphere_medium_bad_quality_exit PROPERTIES WILL_FAIL TRUE LABELS "example;integrators")
endif()

# Resumable renders (hardening issue): abort hook + real SIGKILL, resumed byte-identical.
if(TARGET vpt_sphere_medium OR (GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/vpt_sphere_medium.cpp))
  add_test(NAME vpt_sphere_medium_resume
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/integrators/resume.sh $<TARGET_FILE:vpt_sphere_medium>
                   ${CMAKE_CURRENT_BINARY_DIR}/resume_work)
  set_tests_properties(vpt_sphere_medium_resume PROPERTIES LABELS "example;integrators;checkpoint" TIMEOUT 300
    PASS_REGULAR_EXPRESSION "byte-identical to the uninterrupted render; foreign checkpoint refused")
endif()

# MPI scale-out (ecosystem issue): 2 ranks give the single-process EXR byte for byte.
if(TARGET MPI::MPI_CXX AND MPIEXEC_EXECUTABLE AND GRAINLIGHT_BUILD_EXAMPLES AND EXISTS ${PROJECT_SOURCE_DIR}/examples/vpt_sphere_medium.cpp)
  add_test(NAME vpt_sphere_medium_mpi
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/common/mpi_compare.sh ${MPIEXEC_EXECUTABLE} 2
                   ${CMAKE_CURRENT_BINARY_DIR}/mpi_vpt_work vpt_sphere_medium.exr $<TARGET_FILE:vpt_sphere_medium>
                   --quality quick --seed 1)
  set_tests_properties(vpt_sphere_medium_mpi PROPERTIES LABELS "example;integrators;mpi" TIMEOUT 300
    PASS_REGULAR_EXPRESSION "byte-identical to one process")
endif()

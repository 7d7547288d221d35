# Included from tests/CMakeLists.txt after test_adapters is defined (only when Embree is found).
target_link_libraries(test_adapters PRIVATE embree)
set_tests_properties(adapters PROPERTIES LABELS "unit;adapters;embree")

# The Embree example end to end: EPT with every query answered by Embree (ground and light
# meshes + the aggregate as a user geometry) and the library's render_ept on the same scene are
# unbiased estimators of the same image: their means agree within ~4 combined standard errors
# (6 x the Embree render's own standard error; measured: 1.9 at 8 spp, 0.5 at 64 spp).
if(TARGET embree_aggregate)
  set(_emb_out ${CMAKE_CURRENT_BINARY_DIR}/embree_out)
  add_test(NAME embree_aggregate_json
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:embree_aggregate>
                   "-DARGS=--quality;quick;--spp;8;--threads;2;--seed;1;--out;${_emb_out}"
                   "-DCHECKS=abs(mean_embree - mean_library) <= 6 * mean_embree_se;mean_embree > 0.05;grains > 40000"
                   -DEXPECT_FILE=${_emb_out}/embree_aggregate.png
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  set_tests_properties(embree_aggregate_json PROPERTIES LABELS "example;adapters;embree" TIMEOUT 300)
endif()

# guo21_ept_embree: Guo21's explicit-sphere EPT through Embree's sphere BVH and through the
# particle grid are two renders of the same spheres (the lookups agree exactly on 4096 rays and
# 4096 points in bench_embree's SpheresCheckSameHits; paths diverge only by float round-off of the
# hit distances): their masked means agree within 4 combined standard errors at every N. Times are
# reported, never asserted.
if(TARGET guo21_ept_embree)
  set(_gee_out ${CMAKE_CURRENT_BINARY_DIR}/guo21_ept_embree_out)
  add_test(NAME guo21_ept_embree_json
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:guo21_ept_embree>
                   "-DARGS=--quality;quick;--threads;2;--seed;1;--out;${_gee_out}"
                   "-DCHECKS=max_z_embree_vs_grid <= 4;rc_over_rp <= 0.1"
                   -DEXPECT_FILE=${_gee_out}/guo21_ept_embree.csv
                   -P ${PROJECT_SOURCE_DIR}/tests/common/check_json.cmake)
  set_tests_properties(guo21_ept_embree_json PROPERTIES LABELS "example;adapters;embree" TIMEOUT 300)
endif()

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

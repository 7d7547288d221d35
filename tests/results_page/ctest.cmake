# Results page of the main job (scripts/make_results_page.py): generated on a synthetic output
# folder (nested folders, names with spaces, a failed program, a PNG outside every program's
# folder); every image and link on it must resolve and every PNG must be shown. Debian's python
# (standard library only). Included from tests/CMakeLists.txt (this area has no C++ sources).
if(EXISTS /usr/bin/python3)
  add_test(NAME results_page
           COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/check_results_page.py
                   --self-test ${PROJECT_SOURCE_DIR}/scripts/make_results_page.py)
  set_tests_properties(results_page PROPERTIES LABELS "unit;results_page" TIMEOUT 60)
endif()

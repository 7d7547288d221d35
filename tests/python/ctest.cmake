# pytest suite of the grainlight Python module (examples/python), against the MIEV0 cases in
# tests/data/mie_reference.md. Registered only when the module is built and pytest is importable
# by the module's interpreter (Debian: python3-pytest). Included from tests/CMakeLists.txt.
if(TARGET grainlight_python)
  execute_process(COMMAND ${GRAINLIGHT_PYTHON_EXECUTABLE} -c "import pytest" RESULT_VARIABLE _gl_pytest_rc OUTPUT_QUIET ERROR_QUIET)
  if(_gl_pytest_rc EQUAL 0)
    add_test(NAME python
             COMMAND ${GRAINLIGHT_PYTHON_EXECUTABLE} -m pytest -q -p no:cacheprovider ${CMAKE_CURRENT_LIST_DIR})
    set_tests_properties(python PROPERTIES LABELS "unit;python" TIMEOUT 300
      ENVIRONMENT "PYTHONPATH=$<TARGET_FILE_DIR:grainlight_python>;GRAINLIGHT_TEST_DATA_DIR=${CMAKE_CURRENT_LIST_DIR}/../data")
  else()
    message(STATUS "grainlight Python tests: pytest not importable by ${GRAINLIGHT_PYTHON_EXECUTABLE} (Debian: python3-pytest); skipped")
  endif()
endif()

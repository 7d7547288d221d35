# Run at build time (`cmake -P`, target grainlight_example_info_update in examples/CMakeLists.txt):
# writes example_info.cpp with the commit the source tree is at *now*, so a rebuild after a
# checkout, a pull or a new commit records that commit in every JSON summary without a reconfigure.
# configure_file rewrites DST only when its text changes, so an unchanged commit recompiles and
# relinks nothing.
# Inputs (-D): SRC (examples/common/example_info.cpp.in), DST, SOURCE_DIR (the project's source
# directory), PROJECT_VERSION, GIT_EXECUTABLE (empty when git is absent: the commit is "unknown").
set(GRAINLIGHT_GIT_COMMIT "unknown")
if(GIT_EXECUTABLE)
  execute_process(COMMAND "${GIT_EXECUTABLE}" rev-parse --short HEAD
                  WORKING_DIRECTORY "${SOURCE_DIR}"
                  OUTPUT_VARIABLE _gl_commit OUTPUT_STRIP_TRAILING_WHITESPACE
                  RESULT_VARIABLE _gl_result ERROR_QUIET)
  if(_gl_result EQUAL 0 AND _gl_commit)
    set(GRAINLIGHT_GIT_COMMIT "${_gl_commit}")
  endif()
endif()
set(PROJECT_SOURCE_DIR "${SOURCE_DIR}")
configure_file("${SRC}" "${DST}" @ONLY)

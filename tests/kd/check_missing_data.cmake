# Runs one test case of a test executable with its data directory pointed at an empty folder:
# without SYLVA_ALLOW_MISSING_DATA it must fail naming the missing file; with
# SYLVA_ALLOW_MISSING_DATA=1 it must exit with 77 (what ctest reports as skipped), never 0.
# cmake -DEXE=... -DSPEC=... -DEMPTY=... -P check_missing_data.cmake
file(MAKE_DIRECTORY "${EMPTY}")
set(ENV{SYLVA_TEST_DATA_DIR} "${EMPTY}")
unset(ENV{SYLVA_ALLOW_MISSING_DATA})
execute_process(COMMAND "${EXE}" "${SPEC}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR rc EQUAL 77 OR NOT out MATCHES "missing test data")
  message(FATAL_ERROR "missing data without SYLVA_ALLOW_MISSING_DATA: exit ${rc}, want a failure naming the file\n${out}${err}")
endif()
set(ENV{SYLVA_ALLOW_MISSING_DATA} 1)
execute_process(COMMAND "${EXE}" "${SPEC}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 77 OR NOT out MATCHES "SKIPPED: missing test data")
  message(FATAL_ERROR "missing data with SYLVA_ALLOW_MISSING_DATA=1: exit ${rc}, want 77 (skipped)\n${out}${err}")
endif()
message(STATUS "${SPEC}: fails without the data, skipped (77) when allowed")

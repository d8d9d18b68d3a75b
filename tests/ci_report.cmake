# ci.earlier_parts_passed (registered when SYLVA_CI_REPORT names a file at configure time; .ci/run
# does that for its last part): prints the report .ci/run wrote about its fuzz, TSan and
# ASan+UBSan parts and fails when one of them failed. CI keeps only the end of the output, and
# this test's output lands there.
#   cmake -DREPORT=FILE -P tests/ci_report.cmake
if(NOT EXISTS "${REPORT}")
  message(FATAL_ERROR "ci report ${REPORT} is missing: .ci/run did not write it")
endif()
file(READ "${REPORT}" text)
message("${text}")
if(text MATCHES "FAILED")
  message(FATAL_ERROR "an earlier part of .ci/run failed (above)")
endif()

# ctest driver of stream_csv (see CMakeLists.txt). Inputs: EXE, DATA_DIR, WORK_DIR.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

function(run_stream)
  execute_process(COMMAND ${EXE} ${DATA_DIR}/detector.json ${DATA_DIR}/data.csv ${ARGN}
                  RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message(STATUS "stream_csv ${ARGN}:\n${out}${err}")
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "stream_csv failed (${code})")
  endif()
endfunction()

# Data rows after the CSV header line.
function(body file var)
  file(READ ${file} text)
  string(FIND "${text}" "\n" eol)
  math(EXPR start "${eol} + 1")
  string(SUBSTRING "${text}" ${start} -1 rest)
  set(${var} "${rest}" PARENT_SCOPE)
endfunction()

# 1. One uninterrupted run: alarms equal the batch alarms.
run_stream(--alarms-csv ${WORK_DIR}/alarms.csv --scores-csv ${WORK_DIR}/scores.csv --json ${WORK_DIR}/alarms.json)
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK_DIR}/alarms.csv ${DATA_DIR}/expected_alarms.csv
                RESULT_VARIABLE differ)
if(differ)
  file(READ ${WORK_DIR}/alarms.csv got)
  file(READ ${DATA_DIR}/expected_alarms.csv expected)
  message(FATAL_ERROR "streaming alarms differ from batch:\n${got}\nexpected:\n${expected}")
endif()
file(READ ${DATA_DIR}/expected_alarms.csv expected)
string(REGEX MATCHALL "\n" lines "${expected}")
list(LENGTH lines n_lines)
if(n_lines LESS 2)
  message(FATAL_ERROR "expected_alarms.csv holds no alarm: the test would prove nothing")
endif()

# 2. Stopped after 6001 samples, checkpointed, resumed by a second process.
run_stream(--checkpoint ${WORK_DIR}/checkpoint.json --stop-after 6001
           --alarms-csv ${WORK_DIR}/alarms1.csv --scores-csv ${WORK_DIR}/scores1.csv)
run_stream(--checkpoint ${WORK_DIR}/checkpoint.json
           --alarms-csv ${WORK_DIR}/alarms2.csv --scores-csv ${WORK_DIR}/scores2.csv)
body(${WORK_DIR}/alarms1.csv a1)
body(${WORK_DIR}/alarms2.csv a2)
body(${DATA_DIR}/expected_alarms.csv a)
if(NOT "${a1}${a2}" STREQUAL "${a}")
  message(FATAL_ERROR "alarms with a restart:\n${a1}${a2}\nexpected:\n${a}")
endif()
body(${WORK_DIR}/scores1.csv s1)
body(${WORK_DIR}/scores2.csv s2)
body(${WORK_DIR}/scores.csv s)
if(NOT "${s1}${s2}" STREQUAL "${s}")
  message(FATAL_ERROR "scores after a restart differ from the uninterrupted run")
endif()
if("${s2}" STREQUAL "")
  message(FATAL_ERROR "the resumed run scored no window")
endif()

# `mpirun -np 2 mfpc batch` writes the output one process writes, timings aside: the scenes are shared
# between the ranks and rank 0 merges their parts in the scenes' order, plain and with each scene's
# foveae placed (--fovea auto). A corrupt scene is an error record in both (exit 3). A --sequence,
# one chain of frames, is refused under mpirun. The scenes and the model are synthesized here, so it
# needs no data.
foreach(var MFPC MPIEXEC WORK_DIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "mpi_batch_test: -D${var}=... is required")
  endif()
endforeach()
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")
foreach(seed 1 2 3)
  execute_process(COMMAND "${MFPC}" --threads 2 -q synth --seed ${seed} --objects 2 --distractors 2
                          --resolution 320x240 -o "${WORK_DIR}/scene${seed}"
                  RESULT_VARIABLE status ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "mfpc synth --seed ${seed} failed (${status}): ${err}")
  endif()
endforeach()
file(WRITE "${WORK_DIR}/corrupt.pcd" "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\n")
file(WRITE "${WORK_DIR}/scenes.txt"
     "scene1/scene.pcd\ncorrupt.pcd\nscene2/scene.pcd\nscene3/scene.pcd\n")

set(batch batch --model "${WORK_DIR}/scene1/carton.mfpcm" --scenes "${WORK_DIR}/scenes.txt")
set(launcher "${MPIEXEC}" -np 2 --oversubscribe)
execute_process(COMMAND id -u OUTPUT_VARIABLE uid OUTPUT_STRIP_TRAILING_WHITESPACE)
if(uid STREQUAL "0")
  list(APPEND launcher --allow-run-as-root)
endif()
# Every record without its timings (the placement's time among them).
function(records file out)
  file(STRINGS "${file}" lines)
  set(result "")
  foreach(line IN LISTS lines)
    string(JSON has_timings ERROR_VARIABLE no_timings GET "${line}" timings_ms)
    if(NOT no_timings)
      string(JSON line REMOVE "${line}" timings_ms)
    endif()
    string(JSON has_placement ERROR_VARIABLE no_placement GET "${line}" placement)
    if(NOT no_placement)
      string(JSON line REMOVE "${line}" placement ms)
    endif()
    list(APPEND result "${line}")
  endforeach()
  set(${out} "${result}" PARENT_SCOPE)
endfunction()

# One process, then two ranks, with the batch options given: the same records.
function(compare name)
  execute_process(COMMAND "${MFPC}" --threads 1 -q ${batch} ${ARGN} -o "${WORK_DIR}/${name}_single.jsonl"
                  RESULT_VARIABLE single_status ERROR_VARIABLE single_err)
  execute_process(COMMAND ${launcher} "${MFPC}" --threads 1 -q ${batch} ${ARGN} -o "${WORK_DIR}/${name}_mpi.jsonl"
                  RESULT_VARIABLE mpi_status ERROR_VARIABLE mpi_err)
  if(NOT single_status EQUAL 3 OR NOT mpi_status EQUAL 3)
    message(FATAL_ERROR "${name}: expected exit 3 (one corrupt scene): single ${single_status}, mpi ${mpi_status}\n"
                        "${single_err}\n${mpi_err}")
  endif()
  file(GLOB parts "${WORK_DIR}/${name}_mpi.jsonl.part-*")
  if(parts)
    message(FATAL_ERROR "${name}: parts left after the merge: ${parts}")
  endif()
  records("${WORK_DIR}/${name}_single.jsonl" single)
  records("${WORK_DIR}/${name}_mpi.jsonl" mpi)
  list(LENGTH single count)
  if(NOT count EQUAL 4)
    message(FATAL_ERROR "${name}: the single-process batch wrote ${count} records, not 4")
  endif()
  if(NOT single STREQUAL mpi)
    message(FATAL_ERROR "${name}: mpirun -np 2 wrote other records than one process:\n${single}\n---\n${mpi}")
  endif()
  set(single "${single}" PARENT_SCOPE)
endfunction()
compare(plain)
compare(placed --fovea auto)
string(FIND "${single}" "\"placement\"" placed)
if(placed EQUAL -1)
  message(FATAL_ERROR "--fovea auto wrote no placement in its records:\n${single}")
endif()

execute_process(COMMAND ${launcher} "${MFPC}" --threads 1 -q ${batch} --sequence -o "${WORK_DIR}/sequence.jsonl"
                RESULT_VARIABLE sequence_status ERROR_VARIABLE sequence_err)
if(sequence_status EQUAL 0 OR NOT sequence_err MATCHES "cannot be shared" OR EXISTS "${WORK_DIR}/sequence.jsonl")
  message(FATAL_ERROR "mpirun -np 2 mfpc batch --sequence was not refused (${sequence_status}):\n${sequence_err}")
endif()
message("mpi_batch_test: 4 records, the same from 2 ranks as from one process, plain and placed; a sequence refused")

# Instrumented builds (docs/sanitizers.md, docs/fuzzing.md). Both apply to every target of the
# build, so one clang build dir serves the sanitizer test run and the libFuzzer targets.
#   MATFIT_SANITIZE=address,undefined   AddressSanitizer + UBSan (any -fsanitize= list)
#   MATFIT_FUZZ=ON                       clang only: coverage for libFuzzer, targets in fuzz/
set(MATFIT_SANITIZE "" CACHE STRING "Sanitizers for every target, e.g. address,undefined")
option(MATFIT_FUZZ "Build the libFuzzer targets in fuzz/ (clang)" OFF)

if(MATFIT_SANITIZE)
  # A report stops the process (no recovery): a test or fuzz run fails on the first finding.
  add_compile_options(-fsanitize=${MATFIT_SANITIZE} -fno-omit-frame-pointer
                      -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${MATFIT_SANITIZE})
endif()

if(MATFIT_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "MATFIT_FUZZ needs clang (libFuzzer): -DCMAKE_CXX_COMPILER=clang++")
  endif()
  # Libraries and tests get coverage hooks; only the fuzz executables link libFuzzer's main.
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()

# The kernels' -O3 (fit/, leaf/) is left out of instrumented builds: -O1 keeps reports precise.
if(MATFIT_SANITIZE OR MATFIT_FUZZ)
  set(MATFIT_KERNEL_OPT "")
else()
  set(MATFIT_KERNEL_OPT "$<$<NOT:$<CONFIG:Debug>>:-O3>")
endif()

# matfit_warnings(target): the project's warning set, applied to every target we own.
function(matfit_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic
                                           -Wno-missing-field-initializers)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")  # clang has no -Wshadow=local
    target_compile_options(${target} PRIVATE -Wshadow=local)
  endif()
  if(MATFIT_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

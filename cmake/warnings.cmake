# matfit_warnings(target): the project's warning set, applied to every target we own.
function(matfit_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow=local
                                           -Wno-missing-field-initializers)
  if(MATFIT_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

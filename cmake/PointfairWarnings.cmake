# Warnings are set per target, never globally.
function(pointfair_set_warnings target)
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow
      -Wconversion -Wno-sign-conversion -Wnon-virtual-dtor -Wold-style-cast
      -Woverloaded-virtual)
    if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
      # The step's AVX2 kernels pass 4-double vectors between internal functions compiled
      # for AVX2; clang warns that their ABI differs from a non-AVX caller's, which never
      # exists (nothing of them is exported).
      target_compile_options(${target} PRIVATE -Wno-psabi)
    endif()
    if(POINTFAIR_WERROR)
      target_compile_options(${target} PRIVATE -Werror)
    endif()
  endif()
endfunction()

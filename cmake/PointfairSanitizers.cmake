# Sanitizer and fuzzing builds (off by default). Unlike warnings, instrumentation has to cover
# every object of the build (ASan's container annotations, UBSan's checks across inlined code,
# libFuzzer's coverage), so these are directory-wide compile options, set only on request.
#
#   -DPOINTFAIR_SANITIZE=address,undefined   any -fsanitize= list (thread for TSan)
#   -DPOINTFAIR_FUZZ=ON                      libFuzzer targets under tests/fuzz (needs clang);
#                                            implies address,undefined plus coverage
set(POINTFAIR_SANITIZE "" CACHE STRING "Build with -fsanitize=<list>, e.g. address,undefined")
option(POINTFAIR_FUZZ "Build the libFuzzer targets of the readers (clang)" OFF)

if(POINTFAIR_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "POINTFAIR_FUZZ needs clang (-DCMAKE_CXX_COMPILER=clang++)")
  endif()
  if(NOT POINTFAIR_SANITIZE)
    set(POINTFAIR_SANITIZE "address,undefined")
  endif()
  # Coverage for libFuzzer in every library; the fuzz targets themselves link -fsanitize=fuzzer.
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()

if(POINTFAIR_SANITIZE)
  add_compile_options(-fsanitize=${POINTFAIR_SANITIZE} -fno-omit-frame-pointer)
  add_link_options(-fsanitize=${POINTFAIR_SANITIZE})
  if(POINTFAIR_SANITIZE MATCHES "undefined")
    # A finding fails the test instead of printing a line and going on.
    add_compile_options(-fno-sanitize-recover=undefined)
  endif()
endif()

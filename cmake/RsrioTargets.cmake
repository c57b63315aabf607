# rsrio_add_test(NAME name SOURCES ... LIBS ... [LABELS ...])
# A Catch2 test executable next to the code it tests, discovered into ctest case by case, with
# the tests' shared helpers (common/tests/support) on its include path.
# Label `concurrency` marks the tests that also run under the thread sanitizer.
function(rsrio_add_test)
  cmake_parse_arguments(T "" "NAME" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${T_NAME} ${T_SOURCES})
  target_link_libraries(${T_NAME} PRIVATE ${T_LIBS} rsrio_test_support Catch2::Catch2WithMain)
  rsrio_target_options(${T_NAME})
  set(props)
  if(T_LABELS)
    # Escaped: a plain list would reach set_tests_properties as separate words, and every label
    # after the first would silently become a property name.
    string(REPLACE ";" "\\;" labels "${T_LABELS}")
    set(props PROPERTIES LABELS "${labels}")
  endif()
  if("concurrency" IN_LIST T_LABELS)
    set_property(GLOBAL APPEND PROPERTY RSRIO_CONCURRENCY_TESTS ${T_NAME})
  endif()
  catch_discover_tests(${T_NAME} WORKING_DIRECTORY ${CMAKE_SOURCE_DIR} ${props}
                       DISCOVERY_MODE PRE_TEST)
endfunction()

# rsrio_add_bench(target): a benchmark program run by the `bench` target. Sanitizer builds leave
# benchmarks out of `all` (timings under a sanitizer mean nothing; they cost build time).
function(rsrio_add_bench target)
  if(RSRIO_SANITIZE)
    set_target_properties(${target} PROPERTIES EXCLUDE_FROM_ALL ON)
  endif()
  set_property(GLOBAL APPEND PROPERTY RSRIO_BENCHES ${target})
endfunction()

# rsrio_add_program(name source libs...): one of the project's programs (installed to bin/).
function(rsrio_add_program name source)
  add_executable(${name} ${source})
  target_link_libraries(${name} PRIVATE ${ARGN})
  rsrio_target_options(${name})
  install(TARGETS ${name} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endfunction()

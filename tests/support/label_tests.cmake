# CTest include script (tests/CMakeLists.txt, TEST_INCLUDE_FILES after the gtest discovery scripts):
# gives the label `long` to every discovered gtest test whose name matches a line of tests/LONG_TESTS.
# Set by the generated caller: _orpe_long_file (the list), _orpe_test_lists (the discovery scripts'
# TEST_LIST variables, <target>_TESTS). A pattern that matches no test is reported (a renamed test).
file(STRINGS "${_orpe_long_file}" _orpe_long_lines)
set(_orpe_long_patterns "")
foreach(_line IN LISTS _orpe_long_lines)
  string(REGEX REPLACE "[ \t]+#.*$" "" _line "${_line}")  # a trailing comment
  string(STRIP "${_line}" _line)
  if(_line AND NOT _line MATCHES "^#")
    list(APPEND _orpe_long_patterns "${_line}")
  endif()
endforeach()
set(_orpe_all_discovered TRUE)
foreach(_list IN LISTS _orpe_test_lists)
  if(NOT DEFINED ${_list})
    set(_orpe_all_discovered FALSE)  # that executable is not built: its tests are not known yet
  endif()
endforeach()
foreach(_pattern IN LISTS _orpe_long_patterns)
  set(_orpe_matched FALSE)
  foreach(_list IN LISTS _orpe_test_lists)
    foreach(_test IN LISTS ${_list})
      if(_test MATCHES "${_pattern}")
        set_tests_properties("${_test}" PROPERTIES LABELS long)
        set(_orpe_matched TRUE)
      endif()
    endforeach()
  endforeach()
  if(NOT _orpe_matched AND _orpe_all_discovered)
    message(WARNING "tests/LONG_TESTS: '${_pattern}' matches no test (renamed? update the list)")
  endif()
endforeach()

# pflow_add_test(NAME name SOURCES ... LABELS unit|gpu|mpi|service|regression [LIBS ...] [TIMEOUT s])
find_package(GTest REQUIRED)
include(GoogleTest)
function(pflow_add_test)
  cmake_parse_arguments(T "" "NAME;TIMEOUT" "SOURCES;LABELS;LIBS" ${ARGN})
  add_executable(${T_NAME} ${T_SOURCES})
  target_link_libraries(${T_NAME} PRIVATE ${T_LIBS} GTest::gtest GTest::gtest_main)
  set_target_properties(${T_NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 600)
  endif()
  list(GET T_LABELS 0 _first)
  gtest_discover_tests(${T_NAME}
    PROPERTIES LABELS "${_first}" TIMEOUT ${T_TIMEOUT}
    WORKING_DIRECTORY ${CMAKE_SOURCE_DIR}
    DISCOVERY_TIMEOUT 60)
  # Several labels (gpu and fault): discovery passes its properties through a command line that splits lists, so
  # the whole list is set after the discovered tests are included.
  list(LENGTH T_LABELS _count)
  if(_count GREATER 1)
    set(_labels_file "${CMAKE_CURRENT_BINARY_DIR}/${T_NAME}_labels.cmake")
    file(WRITE "${_labels_file}"
         "foreach(_t IN LISTS ${T_NAME}_TESTS)\n  set_tests_properties(\"\${_t}\" PROPERTIES LABELS \"${T_LABELS}\")\nendforeach()\n")
    set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${_labels_file}")
  endif()
endfunction()

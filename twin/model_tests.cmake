# Model tests of the thesis (issue 3 item 6): library fl_twin_model_tests, tests
# twin_model_tests (fast ones in the default suite, sweeps labelled `slow`). demlab
# (apps/demlab) writes their CSV and SVG. Included at the end of twin/CMakeLists.txt.
file(GLOB FL_TWIN_MODEL_TESTS_SOURCES CONFIGURE_DEPENDS ${CMAKE_CURRENT_LIST_DIR}/src/model_tests/*.cpp)
add_library(fl_twin_model_tests STATIC ${FL_TWIN_MODEL_TESTS_SOURCES})
target_include_directories(fl_twin_model_tests PUBLIC ${CMAKE_CURRENT_LIST_DIR}/include)
target_link_libraries(fl_twin_model_tests PUBLIC fl_twin_dem fl_twin_fillet
                                          PRIVATE fl_controller_config fl_build_flags)

if(FL_BUILD_TESTS)
  file(GLOB FL_TWIN_MODEL_TESTS_TEST_SOURCES CONFIGURE_DEPENDS
       ${CMAKE_CURRENT_LIST_DIR}/tests/model_tests/*.cpp)
  if(FL_TWIN_MODEL_TESTS_TEST_SOURCES)
    add_executable(twin_model_tests ${FL_TWIN_MODEL_TESTS_TEST_SOURCES})
    target_link_libraries(twin_model_tests PRIVATE fl_twin_model_tests fl_controller_config
                                                   fl_build_flags GTest::gtest_main)
    target_compile_definitions(twin_model_tests PRIVATE FL_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    # Fast tests: default suite. ModelTestsSlow.* are the longer sweeps: label `slow`.
    gtest_discover_tests(twin_model_tests TEST_FILTER "-ModelTestsSlow.*" DISCOVERY_TIMEOUT 60
                         PROPERTIES TIMEOUT 120)
    gtest_discover_tests(twin_model_tests TEST_FILTER "ModelTestsSlow.*" DISCOVERY_TIMEOUT 60
                         PROPERTIES LABELS slow TIMEOUT 1200)
  endif()
endif()

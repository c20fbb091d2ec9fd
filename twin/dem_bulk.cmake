# DEM bulk scene (issue 3, item 2): mailbox hopper with its adjustable gate, bulk belt and
# universal leveller as DEM walls. Library fl_twin_dem_bulk, tools bulk_sweep and bulk_run, tests
# twin_dem_bulk_tests. Included from twin/CMakeLists.txt.
file(GLOB FL_TWIN_DEM_BULK_SOURCES CONFIGURE_DEPENDS ${CMAKE_CURRENT_LIST_DIR}/src/dem_bulk/*.cpp)
if(NOT FL_TWIN_DEM_BULK_SOURCES OR NOT TARGET fl_twin_dem OR NOT TARGET fl_twin_fillet)
  return()
endif()
add_library(fl_twin_dem_bulk STATIC ${FL_TWIN_DEM_BULK_SOURCES})
target_include_directories(fl_twin_dem_bulk PUBLIC ${CMAKE_CURRENT_LIST_DIR}/include)
# fl_twin_fillet for the thesis fillet templates; fl_report for the sweep's CSV.
target_link_libraries(fl_twin_dem_bulk PUBLIC fl_twin_dem fl_twin_fillet fl_controller_config
                                       PRIVATE fl_report fl_build_flags)

add_executable(bulk_sweep ${CMAKE_CURRENT_LIST_DIR}/src/dem_bulk/tools/bulk_sweep.cpp)
target_link_libraries(bulk_sweep PRIVATE fl_twin_dem_bulk CLI11::CLI11 fl_build_flags)
# bulk_run: the thesis' bulk experiment as one timed run (config/bulk_thesis.yaml).
add_executable(bulk_run ${CMAKE_CURRENT_LIST_DIR}/src/dem_bulk/tools/bulk_run.cpp)
# fl_twin_render (OpenCV) for the video; the scene library itself stays without OpenCV.
target_link_libraries(bulk_run PRIVATE fl_twin_dem_bulk fl_twin_render fl_report CLI11::CLI11
                                       nlohmann_json::nlohmann_json spdlog::spdlog fl_build_flags)

if(FL_BUILD_TESTS)
  file(GLOB FL_TWIN_DEM_BULK_TEST_SOURCES CONFIGURE_DEPENDS
       ${CMAKE_CURRENT_LIST_DIR}/tests/dem_bulk/*_test.cpp)
  if(FL_TWIN_DEM_BULK_TEST_SOURCES)
    add_executable(twin_dem_bulk_tests ${FL_TWIN_DEM_BULK_TEST_SOURCES})
    target_link_libraries(twin_dem_bulk_tests PRIVATE fl_twin_dem_bulk fl_report fl_build_flags
                                                      GTest::gtest_main)
    target_compile_definitions(twin_dem_bulk_tests PRIVATE FL_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    # BulkOutflow.* runs a gate sweep (about 15 s each in release, 140 s under the
    # sanitizers) and BulkThesisConfig.* builds the 199k-sphere thesis box: label slow, so the
    # sanitizer run leaves them to release.
    gtest_discover_tests(twin_dem_bulk_tests TEST_FILTER "-BulkOutflow.*:BulkThesisConfig.*"
                         DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 300)
    gtest_discover_tests(twin_dem_bulk_tests TEST_FILTER "BulkOutflow.*:BulkThesisConfig.*"
                         DISCOVERY_TIMEOUT 60 PROPERTIES LABELS slow TIMEOUT 300)
  endif()
endif()

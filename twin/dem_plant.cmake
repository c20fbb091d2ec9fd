# DEM plant (issue 3, item 5): the DEM twin behind the controller's plant interface.
# Library fl_twin_dem_plant, tests twin_dem_plant_tests. Included from twin/CMakeLists.txt.
file(GLOB FL_TWIN_DEM_PLANT_SOURCES CONFIGURE_DEPENDS ${CMAKE_CURRENT_LIST_DIR}/src/dem_plant/*.cpp)
if(NOT FL_TWIN_DEM_PLANT_SOURCES OR NOT TARGET fl_twin_dem OR NOT TARGET fl_twin_fast
   OR NOT TARGET fl_twin_dem_bulk)
  return()
endif()
add_library(fl_twin_dem_plant STATIC ${FL_TWIN_DEM_PLANT_SOURCES})
target_include_directories(fl_twin_dem_plant PUBLIC ${CMAKE_CURRENT_LIST_DIR}/include)
# fl_twin_fast for the shared plant_fast.yaml loader; fl_twin_sensors for the drive and camera
# emulators both plants use.
# fl_twin_dem_bulk for the bulk end as a DEM scene, one of the two infeeds.
target_link_libraries(fl_twin_dem_plant PUBLIC fl_twin_dem fl_twin_fillet fl_twin_sensors fl_twin_fast
                                               fl_twin_dem_bulk fl_controller_config
                                        PRIVATE fl_build_flags)

if(FL_BUILD_TESTS)
  file(GLOB FL_TWIN_DEM_PLANT_TEST_SOURCES CONFIGURE_DEPENDS
       ${CMAKE_CURRENT_LIST_DIR}/tests/dem_plant/*_test.cpp)
  if(FL_TWIN_DEM_PLANT_TEST_SOURCES)
    add_executable(twin_dem_plant_tests ${FL_TWIN_DEM_PLANT_TEST_SOURCES})
    target_link_libraries(twin_dem_plant_tests PRIVATE fl_twin_dem_plant fl_closed_loop
                                                       fl_build_flags GTest::gtest_main)
    target_compile_definitions(twin_dem_plant_tests PRIVATE FL_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    # The bulk end's handover and closed-loop runs and the feeder's pairs take 10 to 20 s of
    # line time each (about half real time here, several times that under the sanitizers):
    # label slow, so the sanitizer run leaves them to release.
    set(FL_DEM_PLANT_SLOW_TESTS
        "DemPlantBulkEnd.HandedOverFilletsKeepVariantSideHeadingAndPlace:DemPlantBulkEnd.ClosedLoopFeedsTheLineFromTheHopper:DemPlantBulkEnd.ALoadOverTheTripTorqueTripsTheLeveller:DemPlantFeeder.TouchingPairsAreFedWhollyOntoTheTaktBelt")
    gtest_discover_tests(twin_dem_plant_tests TEST_FILTER "-${FL_DEM_PLANT_SLOW_TESTS}"
                         DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 300)
    gtest_discover_tests(twin_dem_plant_tests TEST_FILTER "${FL_DEM_PLANT_SLOW_TESTS}"
                         DISCOVERY_TIMEOUT 60 PROPERTIES LABELS slow TIMEOUT 300)
  endif()
endif()

# The DEM line's pace at a steady load of spawned fillets (docs/benchmarks.md, "The DEM line
# against the controller"): a scenario command timed as a whole, not a unit test.
if(FL_BUILD_BENCH)
  add_executable(dem_line_load ${CMAKE_CURRENT_LIST_DIR}/bench/dem_line_load.cpp)
  target_link_libraries(dem_line_load PRIVATE fl_twin_dem_plant fl_controller_config
                                              CLI11::CLI11 fl_build_flags)
  target_compile_definitions(dem_line_load PRIVATE FL_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endif()

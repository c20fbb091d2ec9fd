# Sensor emulators shared by the plants (fast and DEM): cameras and belt drives. The plants
# hand them ground truth and belt commands; they write the sensor side of the InputImage.
# Library fl_twin_sensors, tests twin_sensors_tests. Included from twin/CMakeLists.txt.
add_library(fl_twin_sensors STATIC ${CMAKE_CURRENT_LIST_DIR}/src/sensors/camera_emulator.cpp
                                   ${CMAKE_CURRENT_LIST_DIR}/src/sensors/drive_emulator.cpp)
target_include_directories(fl_twin_sensors PUBLIC ${CMAKE_CURRENT_LIST_DIR}/include)
target_link_libraries(fl_twin_sensors PUBLIC fl_controller_logic PRIVATE fl_build_flags)

if(FL_BUILD_TESTS)
  file(GLOB FL_TWIN_SENSORS_TEST_SOURCES CONFIGURE_DEPENDS
       ${CMAKE_CURRENT_LIST_DIR}/tests/sensors/*_test.cpp)
  if(FL_TWIN_SENSORS_TEST_SOURCES)
    add_executable(twin_sensors_tests ${FL_TWIN_SENSORS_TEST_SOURCES})
    target_link_libraries(twin_sensors_tests PRIVATE fl_twin_sensors fl_build_flags
                                                     GTest::gtest_main)
    gtest_discover_tests(twin_sensors_tests DISCOVERY_TIMEOUT 60)
  endif()
endif()

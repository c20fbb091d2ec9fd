# Fillet meta-particles for the DEM twin (issue 3): triangle meshes, STL files, the procedural
# fillet shape and its sub-particle raster. Included from twin/CMakeLists.txt; self-contained so
# it builds while the DEM engine (dem.cmake) is being written.

add_library(
  fl_twin_fillet STATIC
  ${CMAKE_CURRENT_LIST_DIR}/src/dem/mesh.cpp ${CMAKE_CURRENT_LIST_DIR}/src/dem/stl.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/dem/fillet_shape.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/dem/fillet_generator.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/dem/fillet_bend.cpp)
target_include_directories(fl_twin_fillet PUBLIC ${CMAKE_CURRENT_LIST_DIR}/include)
target_link_libraries(fl_twin_fillet PUBLIC Eigen3::Eigen spdlog::spdlog PRIVATE fl_build_flags)

if(FL_BUILD_TESTS)
  file(GLOB FL_TWIN_FILLET_TEST_SOURCES CONFIGURE_DEPENDS
       ${CMAKE_CURRENT_LIST_DIR}/tests/dem/fillet_*_test.cpp
       ${CMAKE_CURRENT_LIST_DIR}/tests/dem/mesh_*_test.cpp
       ${CMAKE_CURRENT_LIST_DIR}/tests/dem/stl_*_test.cpp)
  if(FL_TWIN_FILLET_TEST_SOURCES)
    add_executable(twin_fillet_tests ${FL_TWIN_FILLET_TEST_SOURCES})
    target_link_libraries(twin_fillet_tests PRIVATE fl_twin_fillet fl_build_flags GTest::gtest_main)
    target_compile_definitions(twin_fillet_tests PRIVATE FL_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    gtest_discover_tests(twin_fillet_tests DISCOVERY_TIMEOUT 60)
  endif()
endif()

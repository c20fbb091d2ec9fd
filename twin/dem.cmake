# DEM engine (issue 3): library fl_twin_dem, tests twin_dem_tests, benchmark bench_dem.
# Included from twin/CMakeLists.txt.
find_package(OpenMP REQUIRED)

# Explicit list: src/dem/ also holds the fillet generator's files (fillet.cmake).
set(FL_TWIN_DEM_DIR ${CMAKE_CURRENT_LIST_DIR}/src/dem)
add_library(
  fl_twin_dem STATIC
  ${FL_TWIN_DEM_DIR}/laws.cpp ${FL_TWIN_DEM_DIR}/bpm_vector_kernel.cpp ${FL_TWIN_DEM_DIR}/model.cpp ${FL_TWIN_DEM_DIR}/geometry.cpp
  ${FL_TWIN_DEM_DIR}/simulation.cpp ${FL_TWIN_DEM_DIR}/config.cpp
  ${FL_TWIN_DEM_DIR}/vtk_writer.cpp)
target_include_directories(fl_twin_dem PUBLIC ${CMAKE_CURRENT_LIST_DIR}/include)
# fl_twin_fillet: the STL reader, for mesh walls named in the config.
target_link_libraries(fl_twin_dem PUBLIC Eigen3::Eigen OpenMP::OpenMP_CXX fl_controller_config
                                  PRIVATE fl_build_flags fl_twin_fillet)
# The engine never reads errno: without this GCC guards every sqrt in the pair and bond loops
# with a branch to the library call that would set it.
target_compile_options(fl_twin_dem PRIVATE -fno-math-errno)

if(FL_BUILD_TESTS)
  file(GLOB FL_TWIN_DEM_TEST_SOURCES CONFIGURE_DEPENDS ${CMAKE_CURRENT_LIST_DIR}/tests/dem/dem_*_test.cpp)
  if(FL_TWIN_DEM_TEST_SOURCES)
    add_executable(twin_dem_tests ${FL_TWIN_DEM_TEST_SOURCES})
    target_link_libraries(twin_dem_tests PRIVATE fl_twin_dem fl_build_flags GTest::gtest_main)
    target_compile_definitions(twin_dem_tests PRIVATE FL_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
    gtest_discover_tests(twin_dem_tests DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 600)
  endif()
endif()

if(FL_BUILD_BENCH AND EXISTS ${CMAKE_CURRENT_LIST_DIR}/bench/bench_dem.cpp)
  add_executable(bench_dem ${CMAKE_CURRENT_LIST_DIR}/bench/bench_dem.cpp)
  target_link_libraries(bench_dem PRIVATE fl_twin_dem benchmark::benchmark fl_build_flags)
  # One timed scenario in the peers' output format (bench/dem_race/run.sh).
  add_executable(dem_race ${CMAKE_CURRENT_LIST_DIR}/bench/dem_race.cpp)
  target_link_libraries(dem_race PRIVATE fl_twin_dem CLI11::CLI11 fl_build_flags)
endif()

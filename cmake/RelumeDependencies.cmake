# Third-party libraries, all from Debian 12 packages (scripts/install-deps.sh installs them).
find_package(PkgConfig REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(OpenCV 4 REQUIRED COMPONENTS core)
find_package(spdlog REQUIRED)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(GTest REQUIRED)
if(RELUME_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()

# GeographicLib ships no CMake config package on Debian: use pkg-config.
pkg_check_modules(GEOGRAPHICLIB REQUIRED IMPORTED_TARGET geographiclib)
# ERFA (IAU SOFA-derived) is the independent reference for the sun position tests.
pkg_check_modules(ERFA REQUIRED IMPORTED_TARGET erfa)
# Camera raw files (core/raw_file.h).
pkg_check_modules(LIBRAW REQUIRED IMPORTED_TARGET libraw)

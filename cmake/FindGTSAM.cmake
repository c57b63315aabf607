# FindGTSAM: imports Debian's libgtsam-dev (4.2) as GTSAM::gtsam.
#
# Why not GTSAM's own config: Debian's exported GTSAMConfig names libCppUnitLite.a, which the package
# does not ship, so find_package(GTSAM CONFIG) fails (SPEC Sec. 3). We import libgtsam.so directly
# and give it the interface its config would have given: the Boost components it was built against,
# Eigen3 (GTSAM_USE_SYSTEM_EIGEN) and TBB (GTSAM_USE_TBB, TBB allocator).
#
# Result: GTSAM_FOUND, GTSAM_VERSION, GTSAM_INCLUDE_DIR, GTSAM_LIBRARY, target GTSAM::gtsam.

find_path(GTSAM_INCLUDE_DIR gtsam/config.h)
find_library(GTSAM_LIBRARY NAMES gtsam)

if(GTSAM_INCLUDE_DIR AND EXISTS "${GTSAM_INCLUDE_DIR}/gtsam/config.h")
  file(STRINGS "${GTSAM_INCLUDE_DIR}/gtsam/config.h" _gtsam_ver REGEX "#define GTSAM_VERSION_(MAJOR|MINOR|PATCH) ")
  foreach(part MAJOR MINOR PATCH)
    string(REGEX REPLACE ".*#define GTSAM_VERSION_${part} ([0-9]+).*" "\\1" GTSAM_VERSION_${part} "${_gtsam_ver}")
  endforeach()
  set(GTSAM_VERSION "${GTSAM_VERSION_MAJOR}.${GTSAM_VERSION_MINOR}.${GTSAM_VERSION_PATCH}")
  file(STRINGS "${GTSAM_INCLUDE_DIR}/gtsam/config.h" _gtsam_tbb REGEX "#define GTSAM_USE_TBB")
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(GTSAM REQUIRED_VARS GTSAM_LIBRARY GTSAM_INCLUDE_DIR VERSION_VAR GTSAM_VERSION)

if(GTSAM_FOUND AND NOT TARGET GTSAM::gtsam)
  find_package(Boost 1.67 REQUIRED CONFIG COMPONENTS
               serialization system filesystem thread program_options date_time timer chrono regex)
  find_package(Eigen3 3.3 REQUIRED NO_MODULE)
  set(_gtsam_deps Boost::serialization Boost::system Boost::filesystem Boost::thread
      Boost::program_options Boost::date_time Boost::timer Boost::chrono Boost::regex Eigen3::Eigen)
  if(_gtsam_tbb)
    find_package(TBB REQUIRED CONFIG)
    list(APPEND _gtsam_deps TBB::tbb TBB::tbbmalloc)
  endif()
  add_library(GTSAM::gtsam SHARED IMPORTED)
  set_target_properties(GTSAM::gtsam PROPERTIES
    IMPORTED_LOCATION "${GTSAM_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${GTSAM_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${_gtsam_deps}")
endif()
mark_as_advanced(GTSAM_INCLUDE_DIR GTSAM_LIBRARY)

# FindOpenCVModules: imports the OpenCV modules rsrio uses (core, imgproc, imgcodecs) as
# OpenCV::core, OpenCV::imgproc, OpenCV::imgcodecs.
#
# Why not OpenCVConfig.cmake: Debian ships it only in libopencv-dev, which pulls in every OpenCV
# module (video I/O, DNN, GUI toolkits: over a gigabyte). The per-module -dev packages we install
# carry the headers and libraries but no CMake config, so we import those three directly.

find_path(OpenCVModules_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
set(_ocv_vars OpenCVModules_INCLUDE_DIR)
foreach(m IN ITEMS core imgproc imgcodecs)
  find_library(OpenCVModules_${m}_LIBRARY NAMES opencv_${m})
  list(APPEND _ocv_vars OpenCVModules_${m}_LIBRARY)
  mark_as_advanced(OpenCVModules_${m}_LIBRARY)
endforeach()
if(OpenCVModules_INCLUDE_DIR AND EXISTS "${OpenCVModules_INCLUDE_DIR}/opencv2/core/version.hpp")
  file(STRINGS "${OpenCVModules_INCLUDE_DIR}/opencv2/core/version.hpp" _ocv_ver
       REGEX "#define CV_VERSION_(MAJOR|MINOR|REVISION) ")
  foreach(part MAJOR MINOR REVISION)
    string(REGEX REPLACE ".*#define CV_VERSION_${part} +([0-9]+).*" "\\1" _v_${part} "${_ocv_ver}")
  endforeach()
  set(OpenCVModules_VERSION "${_v_MAJOR}.${_v_MINOR}.${_v_REVISION}")
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(OpenCVModules REQUIRED_VARS ${_ocv_vars} VERSION_VAR OpenCVModules_VERSION)

if(OpenCVModules_FOUND)
  set(_ocv_prev "")
  foreach(m IN ITEMS core imgproc imgcodecs)
    if(NOT TARGET OpenCV::${m})
      add_library(OpenCV::${m} SHARED IMPORTED)
      set_target_properties(OpenCV::${m} PROPERTIES
        IMPORTED_LOCATION "${OpenCVModules_${m}_LIBRARY}"
        INTERFACE_INCLUDE_DIRECTORIES "${OpenCVModules_INCLUDE_DIR}"
        INTERFACE_LINK_LIBRARIES "${_ocv_prev}")
    endif()
    set(_ocv_prev OpenCV::${m})
  endforeach()
endif()
mark_as_advanced(OpenCVModules_INCLUDE_DIR)

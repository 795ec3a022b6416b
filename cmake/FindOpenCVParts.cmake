# Debian's libopencv-{core,imgproc,imgcodecs}-dev ship headers and libraries but no CMake
# config (that comes with the libopencv-dev meta-package and all of OpenCV). This finds the
# three parts armsig uses and defines OpenCVParts::OpenCVParts.
find_path(OpenCVParts_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4)
find_library(OpenCVParts_CORE opencv_core)
find_library(OpenCVParts_IMGPROC opencv_imgproc)
find_library(OpenCVParts_IMGCODECS opencv_imgcodecs)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(OpenCVParts REQUIRED_VARS
  OpenCVParts_INCLUDE_DIR OpenCVParts_CORE OpenCVParts_IMGPROC OpenCVParts_IMGCODECS)
if(OpenCVParts_FOUND AND NOT TARGET OpenCVParts::OpenCVParts)
  add_library(OpenCVParts::OpenCVParts INTERFACE IMPORTED)
  set_target_properties(OpenCVParts::OpenCVParts PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${OpenCVParts_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${OpenCVParts_IMGPROC};${OpenCVParts_CORE}")
endif()
# The codecs (PNG decoding) only for the tests that read figures back: linked into armsig they
# would load some 120 shared libraries (GDAL, Poppler, HDF5…) at every start; armsig writes its
# PNGs with libpng.
if(OpenCVParts_FOUND AND NOT TARGET OpenCVParts::Codecs)
  add_library(OpenCVParts::Codecs INTERFACE IMPORTED)
  set_target_properties(OpenCVParts::Codecs PROPERTIES
    INTERFACE_LINK_LIBRARIES "${OpenCVParts_IMGCODECS};OpenCVParts::OpenCVParts")
endif()

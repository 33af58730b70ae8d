# PCL, found by hand (included by CMakeLists.txt and fuzz/CMakeLists.txt): Debian's PCLConfig drags in
# VTK, whose exported targets fail to generate without MPI, and the core needs only a few of PCL's
# libraries (no VTK at all). Sets PCL_INCLUDE_DIR and FE_PCL_LIBS.
find_path(PCL_INCLUDE_DIR pcl/point_types.h PATH_SUFFIXES pcl-1.13 pcl-1.12 pcl-1.11 pcl-1.10 REQUIRED)
foreach(c common kdtree search octree sample_consensus features)
  find_library(PCL_${c}_LIB NAMES pcl_${c} REQUIRED)
  list(APPEND FE_PCL_LIBS ${PCL_${c}_LIB})
endforeach()
find_library(FLANN_CPP_LIB NAMES flann_cpp REQUIRED)
list(APPEND FE_PCL_LIBS ${FLANN_CPP_LIB})

# Run by `cmake --install`: the folders of the installed layout for the prefix given at install
# time (see the top CMakeLists.txt). Sets FE_PYTHON_DIR and FE_MOD_DIR (absolute).
if(FE_PYTHON_INSTALL_DIR)
  set(FE_PYTHON_DIR "${FE_PYTHON_INSTALL_DIR}")
elseif(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(FE_PYTHON_DIR "/usr/lib/python3/dist-packages")
elseif(CMAKE_INSTALL_PREFIX STREQUAL "/usr/local")
  set(FE_PYTHON_DIR "/usr/local/lib/python${FE_PYTHON_VERSION}/dist-packages")
else()  # a user prefix (~/.local): Python's user site folder there
  set(FE_PYTHON_DIR "${CMAKE_INSTALL_PREFIX}/lib/python${FE_PYTHON_VERSION}/site-packages")
endif()
if(NOT IS_ABSOLUTE "${FE_PYTHON_DIR}")
  set(FE_PYTHON_DIR "${CMAKE_INSTALL_PREFIX}/${FE_PYTHON_DIR}")
endif()
if(FE_FREECAD_MOD_DIR)
  set(FE_MOD_DIR "${FE_FREECAD_MOD_DIR}")
elseif(CMAKE_INSTALL_PREFIX STREQUAL "/usr" OR CMAKE_INSTALL_PREFIX STREQUAL "/usr/local")
  set(FE_MOD_DIR "/usr/share/freecad/Mod")  # the only system Mod folder Debian's FreeCAD reads
else()
  set(FE_MOD_DIR "${CMAKE_INSTALL_PREFIX}/share/FreeCAD/Mod")
endif()
message(STATUS "FeatureExtract: Python module in ${FE_PYTHON_DIR}, workbench in ${FE_MOD_DIR}/FeatureExtract")

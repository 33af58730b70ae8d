# Run by `cmake --install` after install_layout.cmake: the workbench, its icons, the shipped feature
# library, the license and the installed package.xml into ${FE_MOD_DIR}/FeatureExtract.
set(_dest "${FE_MOD_DIR}/FeatureExtract")
file(INSTALL "${FE_SOURCE_DIR}/FeatureExtractWB/" DESTINATION "${_dest}"
     PATTERN "__pycache__" EXCLUDE PATTERN "package.xml" EXCLUDE)
file(INSTALL "${FE_SOURCE_DIR}/Resources/icons" "${FE_SOURCE_DIR}/Resources/library" DESTINATION "${_dest}/Resources")
file(INSTALL "${FE_SOURCE_DIR}/LICENSE" "${FE_BINARY_DIR}/installed/package.xml" DESTINATION "${_dest}")

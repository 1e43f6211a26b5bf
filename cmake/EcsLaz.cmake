# The LAZ codec: rust/ecs_laz (the laz crate behind a C ABI), built by cargo as a static library
# with the crate versions of its Cargo.lock, and linked into pcl_ecs_io. PCL_ECS_WITH_LAZ=OFF
# builds without it (LAS is still read and written; LAZ is refused with a message).
option(PCL_ECS_WITH_LAZ "Read and write LAZ through the laz crate (needs cargo)" ON)
if(NOT PCL_ECS_WITH_LAZ)
  return()
endif()
find_program(PCL_ECS_CARGO cargo HINTS $ENV{HOME}/.cargo/bin $ENV{CARGO_HOME}/bin)
if(NOT PCL_ECS_CARGO)
  message(FATAL_ERROR "PCL_ECS_WITH_LAZ is ON but cargo was not found: install Rust (rustup) or "
                      "configure with -DPCL_ECS_WITH_LAZ=OFF to build without LAZ")
endif()
set(PCL_ECS_LAZ_DIR ${PROJECT_SOURCE_DIR}/rust/ecs_laz)
set(PCL_ECS_LAZ_TARGET_DIR ${PROJECT_BINARY_DIR}/rust)
set(PCL_ECS_LAZ_LIB ${PCL_ECS_LAZ_TARGET_DIR}/release/libecs_laz.a)
add_custom_command(
  OUTPUT ${PCL_ECS_LAZ_LIB}
  COMMAND ${CMAKE_COMMAND} -E env CARGO_TARGET_DIR=${PCL_ECS_LAZ_TARGET_DIR}
          ${PCL_ECS_CARGO} build --release --locked --quiet --manifest-path ${PCL_ECS_LAZ_DIR}/Cargo.toml
  DEPENDS ${PCL_ECS_LAZ_DIR}/Cargo.toml ${PCL_ECS_LAZ_DIR}/Cargo.lock ${PCL_ECS_LAZ_DIR}/src/lib.rs
  COMMENT "Building the LAZ codec (cargo: rust/ecs_laz)"
  VERBATIM)
add_custom_target(ecs_laz_build DEPENDS ${PCL_ECS_LAZ_LIB})

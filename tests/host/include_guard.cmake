# Fails (ctest host_include_guard) when a file of host/ outside the in-process
# backend includes a bridge/ or physics/ header (DESIGN.md, "One SNP path":
# the driver and Evaluate know the robot only through SNP bytes).
# Allowed everywhere: physics/morphology.h and physics/script.h, the robot
# description model and its XML parsers (no world, no ODE); the RPC API and
# the driver still take and return a physics::Morphology value; and
# physics/orientation.h, the gravity-direction estimator on accelerometer
# samples (plain Eigen, no world), which GetOrientation runs on the samples a
# real robot or a simulation sends over SNP.
# Also allowed: the renderer's headers (physics/render/: the scene value, its
# conversion from the SNP scene snapshot, cameras, images, the renderer, and
# raster_threads.h, which yamord's main calls before any thread starts; and
# video.h, through which a filmed Evaluate pipes its frames to ffmpeg). The
# host draws what a ReadScene bridge special returned (RenderFrame,
# RecordFrames); none of them touches a world or ODE.
# Run: cmake -DSOURCE_DIR=<repo> -P tests/host/include_guard.cmake
cmake_policy(SET CMP0057 NEW)  # if(... IN_LIST ...)
file(GLOB host_files "${SOURCE_DIR}/host/*.h" "${SOURCE_DIR}/host/*.cc")
set(backend_files sim_backend.h sim_backend.cc)
set(allowed_headers physics/morphology.h physics/script.h physics/orientation.h
    physics/render/scene.h physics/render/snapshot.h physics/render/camera.h
    physics/render/image.h physics/render/renderer.h physics/render/raster_threads.h
    physics/render/video.h)
set(violations "")
foreach(path IN LISTS host_files)
  get_filename_component(name "${path}" NAME)
  if(name IN_LIST backend_files)
    continue()
  endif()
  file(STRINGS "${path}" includes REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<](bridge|physics)/")
  foreach(line IN LISTS includes)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*[\"<]([^\">]+)[\">].*$" "\\1" header "${line}")
    if(NOT header IN_LIST allowed_headers)
      string(APPEND violations "  host/${name}: #include \"${header}\"\n")
    endif()
  endforeach()
endforeach()
if(violations)
  message(FATAL_ERROR "host/ reaches into the simulation outside host/sim_backend.*:\n"
                      "${violations}Talk to the robot through SnpLink (bridge specials, docs/snp.md).")
endif()
list(LENGTH host_files count)
message(STATUS "host include guard: ${count} files checked, none reaches into bridge/ or physics/")

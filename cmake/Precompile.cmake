# Precompiled headers: the heavy third-party headers (Eigen, Ceres, Boost.Asio, fmt/spdlog,
# nlohmann-json, yaml-cpp, CLI11, GoogleTest) parsed once per target instead of once per
# source file: parsing them is a fifth to a half of a source's compile time. Off under
# ccache, which cannot reuse a compile that read a precompiled header (and is the faster path
# where it is used).
option(ARMSIG_PCH "Precompile the heavy third-party headers of each target" ON)
if(ARMSIG_PCH AND CMAKE_CXX_COMPILER_LAUNCHER MATCHES "ccache")
  message(STATUS "armsig: precompiled headers off under ccache (ARMSIG_PCH)")
  set(ARMSIG_PCH OFF)
endif()

# The headers every target's sources use; a target adds its own.
set(ARMSIG_PCH_COMMON
    <algorithm> <cmath> <cstdint> <functional> <map> <memory> <optional> <set> <string>
    <string_view> <vector> <Eigen/Core> <Eigen/Geometry> <fmt/format.h>)

# armsig_precompile(TARGET [HEADER...]): the common headers and HEADERs precompiled for
# TARGET (when ARMSIG_PCH is on).
function(armsig_precompile target)
  if(ARMSIG_PCH)
    target_precompile_headers(${target} PRIVATE ${ARMSIG_PCH_COMMON} ${ARGN})
  endif()
endfunction()

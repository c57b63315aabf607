# Warnings as errors for every target of the project (not for generated code, see rsrio_msgs).
# Sanitizers come from the presets through RSRIO_SANITIZE (address,undefined | thread).
set(RSRIO_SANITIZE "" CACHE STRING "Sanitizers to build with: address,undefined or thread")

set(RSRIO_WARNINGS -Wall -Wextra -Wpedantic -Werror -Wshadow -Wnon-virtual-dtor -Wcast-align
    -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough -Wformat=2)

# Sanitizer presets compile with -O1 -g1 (CMakePresets.json): line tables are all a sanitizer
# report needs, and it builds ~40 % faster than RelWithDebInfo's -O2 -g on these 2-core machines.
if(RSRIO_SANITIZE)
  add_compile_options(-fsanitize=${RSRIO_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${RSRIO_SANITIZE})
  if(RSRIO_SANITIZE MATCHES "address")
    # Eigen stops trusting malloc's 16-byte alignment under __SANITIZE_ADDRESS__ and switches to its
    # own offset allocator, while Debian's libgtsam (built without ASan) frees the same matrices with
    # plain free(): a bad-free in NoiseModelFactor::linearize. ASan's malloc is 16-byte aligned on
    # x86-64 and arm64, so telling Eigen so keeps both sides on one allocator.
    add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1)
  endif()
endif()

function(rsrio_target_options target)
  target_compile_options(${target} PRIVATE ${RSRIO_WARNINGS})
endfunction()

# A compiler cache when one is installed (the build root has one, in the root itself, so a fresh
# clone on a machine with the cached root rebuilds from cache; see ./rsrio and enter-root.sh).
option(RSRIO_CCACHE "Compile through ccache when it is installed" ON)
find_program(RSRIO_CCACHE_PROGRAM ccache)
if(RSRIO_CCACHE AND RSRIO_CCACHE_PROGRAM)
  set(CMAKE_C_COMPILER_LAUNCHER ${RSRIO_CCACHE_PROGRAM})
  set(CMAKE_CXX_COMPILER_LAUNCHER ${RSRIO_CCACHE_PROGRAM})
endif()

# Warnings as errors for every target of the project (not for generated code, see rsrio_msgs).
# Sanitizers come from the presets through RSRIO_SANITIZE (address,undefined | thread).
set(RSRIO_SANITIZE "" CACHE STRING "Sanitizers to build with: address,undefined or thread")

set(RSRIO_WARNINGS -Wall -Wextra -Wpedantic -Werror -Wshadow -Wnon-virtual-dtor -Wcast-align
    -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough -Wformat=2)

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

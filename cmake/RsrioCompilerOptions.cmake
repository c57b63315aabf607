# Warnings as errors for every target of the project (not for generated code, see rsrio_msgs).
# Sanitizers come from the presets through RSRIO_SANITIZE (address,undefined | thread).
set(RSRIO_SANITIZE "" CACHE STRING "Sanitizers to build with: address,undefined or thread")

set(RSRIO_WARNINGS -Wall -Wextra -Wpedantic -Werror -Wshadow -Wnon-virtual-dtor -Wcast-align
    -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough -Wformat=2)

if(RSRIO_SANITIZE)
  add_compile_options(-fsanitize=${RSRIO_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${RSRIO_SANITIZE})
endif()

function(rsrio_target_options target)
  target_compile_options(${target} PRIVATE ${RSRIO_WARNINGS})
endfunction()

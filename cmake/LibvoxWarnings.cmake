# Warning flags for libvox's own targets (third-party headers come in as system includes).
add_library(libvox_warnings INTERFACE)
target_compile_options(libvox_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align -Wunused
  -Woverloaded-virtual -Wimplicit-fallthrough -Wno-missing-field-initializers
  $<$<BOOL:${LIBVOX_WERROR}>:-Werror>)

/// @file toml_impl.cpp
/// The one translation unit that compiles toml++'s parser into numen_sim (TOML_IMPLEMENTATION),
/// from the build tree's copy of Debian's headers with upstream PR #305 applied
/// (sim/CMakeLists.txt, docs/scenes.md "toml++"). Every other file includes toml++ with
/// TOML_HEADER_ONLY=0 and links against these definitions.

#define TOML_IMPLEMENTATION
#include <toml++/toml.h>

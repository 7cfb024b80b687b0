// Command-line values the tools share: x,y,z vectors and the pinhole camera options of
// voxinspect render (.esvo and .rvol alike).
#pragma once

#include <vox/base/math.h>
#include <vox/raycast.h>

#include <CLI/CLI.hpp>

#include <string>

namespace vox::tools {

/// Parses "x,y,z" (three finite numbers, nothing after them). @throws UsageError naming
/// @p option: "OPTION expects x,y,z (got 'TEXT')".
[[nodiscard]] Vec3d parseVector(const std::string& text, const char* option);

/// --eye, --target (required), --up, --fov, --width, --height (docs/cli.md, render).
struct CameraOptions {
    std::string eye, target, up = "0,1,0";
    double fov = 60;
    int width = 512, height = 512;

    /// Adds the options to @p command.
    void add(CLI::App& command);
    /// The camera they describe, checked (PinholeCamera::validate). @throws UsageError.
    [[nodiscard]] PinholeCamera camera() const;
};

}  // namespace vox::tools

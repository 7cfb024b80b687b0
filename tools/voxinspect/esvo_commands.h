// voxinspect's .esvo commands: info, validate, dump, render (RvolCommands takes info, validate and
// render over for .rvol files and adds options of its own to render).
#pragma once

#include "../common/camera_options.h"

#include <CLI/CLI.hpp>

#include <string>

namespace vox::tools {

struct EsvoCommands {
    // info / validate / dump
    std::string file;
    bool json = false;
    long long slice = -1;
    // render
    std::string output, depthOut, stats, channel = "depth";
    CameraOptions camera;  // --eye --target --up --fov --width --height
    unsigned maxLevel = 0xFFFFFFFFu;
    unsigned loadLevels = 0xFFFFFFFFu;
    double lodScale = 1.0;
    int beam = -1;  // not given: 8, or 0 for --channel iterations
    bool filter = false;

    CLI::App* info = nullptr;
    CLI::App* validate = nullptr;
    CLI::App* dump = nullptr;
    CLI::App* render = nullptr;

    void add(CLI::App& app);
    /// Runs the parsed command; false if none of these was parsed.
    bool run();
};

}  // namespace vox::tools

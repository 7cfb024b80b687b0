// voxinspect's .esvo commands: info, validate, dump, render.
#pragma once

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
    std::string eye, target, up = "0,1,0";
    double fov = 60;
    int width = 512, height = 512;
    unsigned maxLevel = 0xFFFFFFFFu;
    unsigned loadLevels = 0xFFFFFFFFu;
    double lodScale = 1.0;
    int beam = 0;
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

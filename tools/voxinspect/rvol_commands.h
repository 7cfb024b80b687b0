// voxinspect's .rvol commands: info, validate and render (the subcommands EsvoCommands adds,
// taken over when their file ends in .rvol), sample and slices.
#pragma once

#include "esvo_commands.h"

#include <vox/formats/rvol_tiles.h>

#include <CLI/CLI.hpp>

#include <string>

namespace vox::tools {

struct RvolCommands {
    // sample, slices
    std::string file;
    bool json = false;
    std::string at, dir;
    int level = 0;
    std::string outputDir, axis = "z";
    long long index = -1;  // level-0 cell; -1: the middle
    double exposure = 1;   // slices and render
    unsigned maxOpenTiles = rvol::TiledRvolReaderOptions{}.maxOpenTiles;  // sample and render
    // render (options of the render command EsvoCommands adds)
    std::string scene, esvo;
    double specAperture = 10, shadowAperture = 10;
    bool noShadowCones = false;
    std::string lightcuts = "auto", lightcutCriterion = "rss";
    double lightcutError = 0.02;
    unsigned lightcutMaxCut = 1000;
    bool lightcutsCompare = false;

    CLI::App* sample = nullptr;
    CLI::App* slices = nullptr;
    EsvoCommands* shared = nullptr;

    /// Adds sample and slices to @p app and the .rvol options to @p esvo's render command.
    void add(CLI::App& app, EsvoCommands& esvo);
    /// Runs the parsed command if it is one of these: sample, slices, or info/validate/render of
    /// an .rvol file. False otherwise (an .esvo command, for EsvoCommands::run). @throws
    /// UsageError where an option of one file kind is given with the other.
    bool run();
};

/// True for a file name ending in .rvol.
[[nodiscard]] bool isRvolFile(const std::string& file);

}  // namespace vox::tools

// What voxelize and voxinspect share: option conventions, and main()'s mapping from
// exceptions to the documented exit codes (docs/cli.md).
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <string>

namespace vox::tools {

/// Options every tool has: -q, -v, --threads.
struct CommonOptions {
    bool quiet = false;
    int verbose = 0;
    int threads = 0;  // 0: all cores
};

/// Adds -q/--quiet, -v/--verbose (repeatable) and --threads N to @p app.
void addCommonOptions(CLI::App& app, CommonOptions& options);

/// Parses the command line and runs @p body with the common options applied (log verbosity,
/// progress bar when stderr is a terminal, thread limit). Returns the process exit code:
/// 0 ok, 1 usage, 2 I/O, 3 invalid data, 4 internal error; every error is one line on stderr
/// as "PROGRAM: error: ...".
int runTool(const std::string& program, CLI::App& app, int argc, char** argv,
            const CommonOptions& options, const std::function<void()>& body);

}  // namespace vox::tools

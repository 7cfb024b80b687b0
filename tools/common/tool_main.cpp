#include "tool_main.h"

#include <vox/base/error.h>
#include <vox/util/log.h>
#include <vox/util/parallel.h>
#include <vox/util/progress.h>

#include <unistd.h>

namespace vox::tools {

void addCommonOptions(CLI::App& app, CommonOptions& options) {
    app.add_flag("-q,--quiet", options.quiet, "Print errors only");
    app.add_flag("-v,--verbose", options.verbose, "Print progress notes (-vv: details)");
    app.add_option("--threads", options.threads, "Worker threads (default: all cores)")
        ->check(CLI::Range(1, 4096));
}

int runTool(const std::string& program, CLI::App& app, int argc, char** argv,
            const CommonOptions& options, const std::function<void()>& body) {
    log::setProgramName(program);
    try {
        app.parse(argc, argv);
    } catch (const CLI::Success& e) {  // --help, --version
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // CLI11 exits with 100+ codes of its own; every usage problem is exit code 1 here.
        log::error(std::string(e.what()) + " (see --help)");
        return static_cast<int>(ExitCode::Usage);
    }
    log::setVerbosity(options.quiet ? log::Verbosity::Quiet
                                    : (options.verbose >= 2
                                           ? log::Verbosity::Debug
                                           : (options.verbose == 1 ? log::Verbosity::Verbose
                                                                   : log::Verbosity::Normal)));
    Progress::setEnabled(!options.quiet && ::isatty(STDERR_FILENO));
    try {
        ThreadLimit threads(options.threads);
        body();
        return static_cast<int>(ExitCode::Ok);
    } catch (const ParameterError& e) {
        log::error(e.commandLineMessage());
        return static_cast<int>(e.exitCode());
    } catch (const Error& e) {
        log::error(e.what());
        return static_cast<int>(e.exitCode());
    } catch (const std::bad_alloc&) {
        log::error("out of memory");
        return static_cast<int>(ExitCode::Internal);
    } catch (const std::exception& e) {
        log::error(std::string("internal error: ") + e.what());
        return static_cast<int>(ExitCode::Internal);
    }
}

}  // namespace vox::tools

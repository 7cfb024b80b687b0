#include <vox/util/parallel.h>

#include <tbb/global_control.h>
#include <tbb/info.h>

namespace vox {

struct ThreadLimit::Control {
    tbb::global_control control;
};

ThreadLimit::ThreadLimit(int threads)
    : control_(std::make_unique<Control>(Control{tbb::global_control(
          tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads > 0 ? threads : hardwareThreads()))})) {}

ThreadLimit::~ThreadLimit() = default;

int ThreadLimit::active() {
    return static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

int ThreadLimit::hardwareThreads() { return tbb::info::default_concurrency(); }

}  // namespace vox

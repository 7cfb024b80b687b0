#include <vox/util/parallel.h>

#include <tbb/global_control.h>
#include <tbb/info.h>

namespace vox {

struct ThreadLimit::Control {
    // Constructed in place: a global_control's limit ends with the object, so it must not be a
    // temporary that is moved from.
    explicit Control(std::size_t threads)
        : control(tbb::global_control::max_allowed_parallelism, threads) {}
    tbb::global_control control;
};

ThreadLimit::ThreadLimit(int threads)
    : control_(std::make_unique<Control>(
          static_cast<std::size_t>(threads > 0 ? threads : hardwareThreads()))) {}

ThreadLimit::~ThreadLimit() = default;

int ThreadLimit::active() {
    return static_cast<int>(
        tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

int ThreadLimit::hardwareThreads() { return tbb::info::default_concurrency(); }

}  // namespace vox

#include <vox/util/progress.h>

#include <cstdio>

namespace vox {
namespace {

std::atomic<bool> progressEnabled{false};
constexpr std::int64_t kRedrawIntervalNs = 100'000'000;  // 10 redraws a second at most
constexpr int kBarWidth = 30;

std::int64_t nowNs() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

}  // namespace

Progress::Progress(std::string label, std::uint64_t total)
    : label_(std::move(label)), total_(total), start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() {
    if (drawn_) draw(true);
}

void Progress::setEnabled(bool enabled) { progressEnabled = enabled; }
bool Progress::enabled() { return progressEnabled; }

void Progress::advance(std::uint64_t units) {
    done_.fetch_add(units, std::memory_order_relaxed);
    if (!progressEnabled) return;
    const std::int64_t now = nowNs();
    std::int64_t next = nextDrawNs_.load(std::memory_order_relaxed);
    // Only the thread that wins the interval draws; the others carry on working.
    if (now < next || !nextDrawNs_.compare_exchange_strong(next, now + kRedrawIntervalNs)) return;
    std::unique_lock lock(drawMutex_, std::try_to_lock);
    if (lock.owns_lock()) draw(false);
}

void Progress::draw(bool final) {
    const std::uint64_t done = std::min(done_.load(), total_);
    const double fraction = total_ ? static_cast<double>(done) / static_cast<double>(total_) : 1.0;
    const int filled = static_cast<int>(fraction * kBarWidth);
    char bar[kBarWidth + 1];
    for (int i = 0; i < kBarWidth; ++i) bar[i] = i < filled ? '#' : '.';
    bar[kBarWidth] = '\0';
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    std::fprintf(stderr, "\r%-24.24s [%s] %5.1f%% %6.1fs%s", label_.c_str(), bar, 100.0 * fraction,
                 seconds, final ? "\r\033[K" : "");
    std::fflush(stderr);
    drawn_ = true;
}

}  // namespace vox

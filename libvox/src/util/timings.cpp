#include <vox/util/timings.h>

#include <algorithm>
#include <sys/resource.h>

namespace vox {

void Timings::add(const std::string& stage, double milliseconds) {
    std::lock_guard lock(mutex_);
    auto it = std::find_if(entries_.begin(), entries_.end(), [&](const auto& e) { return e.first == stage; });
    if (it == entries_.end())
        entries_.emplace_back(stage, milliseconds);
    else
        it->second += milliseconds;
}

std::vector<std::pair<std::string, double>> Timings::entries() const {
    std::lock_guard lock(mutex_);
    return entries_;
}

double Timings::get(const std::string& stage) const {
    std::lock_guard lock(mutex_);
    for (const auto& [name, ms] : entries_)
        if (name == stage) return ms;
    return 0.0;
}

Timings::Scope::Scope(Timings* timings, std::string stage)
    : timings_(timings), stage_(std::move(stage)), start_(std::chrono::steady_clock::now()) {}

Timings::Scope::~Scope() {
    if (timings_)
        timings_->add(stage_, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count());
}

std::uint64_t peakRssBytes() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return static_cast<std::uint64_t>(usage.ru_maxrss) * 1024u;  // Linux reports kilobytes
}

}  // namespace vox

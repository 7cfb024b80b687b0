#include <vox/util/timings.h>

#include <algorithm>
#include <cstdio>
#include <sys/resource.h>
#include <unistd.h>

namespace vox {

void Timings::add(const std::string& stage, double milliseconds) {
    std::lock_guard lock(mutex_);
    auto it = std::find_if(entries_.begin(), entries_.end(),
                           [&](const auto& e) { return e.first == stage; });
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
        timings_->add(stage_, std::chrono::duration<double, std::milli>(
                                  std::chrono::steady_clock::now() - start_)
                                  .count());
}

std::uint64_t peakRssBytes() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return static_cast<std::uint64_t>(usage.ru_maxrss) * 1024u;  // Linux reports kilobytes
}

std::uint64_t currentRssBytes() {
    std::FILE* statm = std::fopen("/proc/self/statm", "r");
    if (!statm) return 0;
    unsigned long long pages = 0, resident = 0;
    const int read = std::fscanf(statm, "%llu %llu", &pages, &resident);
    std::fclose(statm);
    return read == 2 ? resident * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE)) : 0;
}

}  // namespace vox

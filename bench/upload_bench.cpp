// Streaming upload bandwidth of the runtime (runtime/src/upload_ring.cpp) against a plain memcpy
// of the same bytes on the same machine, in the same run: MB/s through the persistently mapped
// ring (fenced copies into a device buffer) and through glNamedBufferSubData, for several part
// sizes, each the median of a few repeats.
// Usage: upload_bench [--mb TOTAL] [--ring-mb R] [--repeat N] [--json FILE]
#include <vox/runtime/gl_context.h>
#include <vox/runtime/upload_ring.h>

#include <GL/glcorearb.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
    std::size_t totalMb = 256, ringMb = 8;
    int repeat = 5;
    std::string json;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto next = [&]() -> std::string {
            if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
            return argv[++i];
        };
        if (a == "--mb")
            totalMb = std::stoul(next());
        else if (a == "--ring-mb")
            ringMb = std::stoul(next());
        else if (a == "--repeat")
            repeat = std::stoi(next());
        else if (a == "--json")
            json = next();
        else {
            std::fprintf(
                stderr,
                "usage: upload_bench [--mb TOTAL] [--ring-mb R] [--repeat N] [--json FILE]\n");
            return 1;
        }
    }
    vox::runtime::HeadlessGlContext context;
    const std::size_t total = totalMb << 20;
    std::vector<std::byte> source(total), host(total);
    for (std::size_t i = 0; i < total; ++i) source[i] = std::byte((i * 2654435761u) >> 24);
    // The destination: a device buffer of a quarter of the total, written round and round (as a
    // pool's pages are), so that the test does not measure allocation.
    const std::size_t target = std::max<std::size_t>(total / 4, 8u << 20);
    GLuint buffer = 0;
    glCreateBuffers(1, &buffer);
    glNamedBufferStorage(buffer, GLsizeiptr(target), nullptr, GL_DYNAMIC_STORAGE_BIT);

    const auto timeIt = [&](auto&& body) {
        std::vector<double> seconds;
        for (int r = 0; r < repeat; ++r) {
            const auto start = Clock::now();
            body();
            glFinish();
            seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
        }
        return double(total) / 1e6 / median(seconds);
    };
    const double memcpyMbs = timeIt([&] { std::memcpy(host.data(), source.data(), total); });
    std::printf("upload bench: %s (%s), %zu MB per run, ring %zu MB, median of %d\n",
                context.renderer().c_str(), context.version().c_str(), totalMb, ringMb, repeat);
    std::printf("memcpy host to host: %.0f MB/s\n", memcpyMbs);
    std::printf("%10s %14s %14s %10s %10s\n", "part KB", "ring MB/s", "subdata MB/s", "ring/memcpy",
                "subdata/memcpy");
    nlohmann::json rows = nlohmann::json::array();
    for (std::size_t part : {std::size_t{8} << 10, std::size_t{64} << 10, std::size_t{1} << 20}) {
        const auto run = [&](vox::runtime::UploadRing& ring) {
            for (std::size_t done = 0; done < total; done += part) {
                const std::size_t n = std::min(part, total - done);
                ring.upload(buffer, done % (target - n + 1) / 4 * 4,
                            std::span(source.data() + done, n));
            }
        };
        vox::runtime::UploadRing persistent(context, ringMb << 20,
                                            vox::runtime::UploadPath::PersistentRing);
        vox::runtime::UploadRing subdata(context, 0, vox::runtime::UploadPath::BufferSubData);
        const double ringMbs = timeIt([&] { run(persistent); });
        const double subMbs = timeIt([&] { run(subdata); });
        std::printf("%10zu %14.0f %14.0f %10.2f %10.2f\n", part >> 10, ringMbs, subMbs,
                    ringMbs / memcpyMbs, subMbs / memcpyMbs);
        rows.push_back({{"part_bytes", part},
                        {"ring_mb_per_s", ringMbs},
                        {"subdata_mb_per_s", subMbs},
                        {"ring_fence_waits", persistent.fenceWaits()}});
    }
    context.throwOnErrors("upload bench");
    glDeleteBuffers(1, &buffer);
    if (!json.empty()) {
        std::ofstream out(json);
        out << nlohmann::json{{"renderer", context.renderer()}, {"gl_version", context.version()},
                              {"total_bytes", total},           {"ring_bytes", ringMb << 20},
                              {"memcpy_mb_per_s", memcpyMbs},   {"rows", rows}}
                   .dump(2)
            << "\n";
    }
    return 0;
}

// Compares the colours and normals of two .esvo files of the same octree (the same voxelize
// settings but --attributes): every voxel's value as a runtime resolves it (stored, or inherited
// from an ancestor), B against A — e.g. compressed against raw. Prints JSON: colour PSNR over 8-bit
// sRGB RGB, normal angle mean / p50 / p99 / max in degrees, per level and over all voxels.
// Usage: attribute_compare A.esvo B.esvo
#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <vector>

namespace {

struct Sample {
    vox::esvo::VoxelPosition position;
    vox::esvo::AttributeValue value;
};

std::vector<Sample> collect(const vox::esvo::EsvoPool& pool) {
    std::vector<Sample> out;
    pool.forEachVoxel([&](const vox::esvo::VoxelPosition& p, const vox::esvo::AttributeValue* v) {
        out.push_back({p, v ? *v : vox::esvo::AttributeValue{}});
    });
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        if (argc != 3) throw vox::UsageError("usage: attribute_compare A.esvo B.esvo");
        const vox::esvo::EsvoReader ra(argv[1]), rb(argv[2]);
        vox::esvo::EsvoPool pa(ra), pb(rb);
        pa.loadAll();
        pb.loadAll();
        const std::vector<Sample> a = collect(pa), b = collect(pb);
        if (a.size() != b.size())
            throw vox::InvalidDataError(argv[2],
                                        "holds a different octree than " + std::string(argv[1]));
        const std::uint32_t depth = ra.header().leafDepth;
        std::vector<double> squared(depth + 1, 0.0);
        std::vector<std::uint64_t> counts(depth + 1, 0);
        std::vector<std::vector<double>> angles(depth + 1);
        for (std::size_t i = 0; i < a.size(); ++i) {
            if (!(a[i].position == b[i].position))
                throw vox::InvalidDataError(
                    argv[2], "holds a different octree than " + std::string(argv[1]));
            const std::uint32_t l = a[i].position.level;
            for (unsigned ch = 0; ch < 3; ++ch) {
                const double d = double(vox::esvo::colorChannel(a[i].value.color, ch)) -
                                 double(vox::esvo::colorChannel(b[i].value.color, ch));
                squared[l] += d * d;
            }
            const auto& n = a[i].value.normal;
            const auto& m = b[i].value.normal;
            const double c = std::clamp(
                double(n[0]) * m[0] + double(n[1]) * m[1] + double(n[2]) * m[2], -1.0, 1.0);
            angles[l].push_back(std::acos(c) * 180.0 / 3.14159265358979323846);
            ++counts[l];
        }
        const auto summary = [](std::vector<double> v, double sq, std::uint64_t n) {
            std::sort(v.begin(), v.end());
            double sum = 0;
            for (double x : v) sum += x;
            const double mse = n ? sq / (3.0 * double(n)) : 0.0;
            return nlohmann::json{
                {"voxels", n},
                {"color_psnr_db", mse > 0 ? 10 * std::log10(255.0 * 255.0 / mse) : 99.0},
                {"normal_mean_deg", v.empty() ? 0.0 : sum / double(v.size())},
                {"normal_p50_deg", v.empty() ? 0.0 : v[v.size() / 2]},
                {"normal_p99_deg", v.empty() ? 0.0 : v[v.size() * 99 / 100]},
                {"normal_max_deg", v.empty() ? 0.0 : v.back()}};
        };
        nlohmann::json out{{"a", argv[1]}, {"b", argv[2]}};
        std::vector<double> all;
        double allSquared = 0;
        std::uint64_t allCount = 0;
        nlohmann::json levels = nlohmann::json::array();
        for (std::uint32_t l = 1; l <= depth; ++l) {
            levels.push_back(summary(angles[l], squared[l], counts[l]));
            all.insert(all.end(), angles[l].begin(), angles[l].end());
            allSquared += squared[l];
            allCount += counts[l];
        }
        out["all"] = summary(all, allSquared, allCount);
        out["levels_1_and_below"] = levels;
        std::cout << out.dump(2) << "\n";
        return 0;
    } catch (const vox::Error& e) {
        std::fprintf(stderr, "attribute_compare: error: %s\n", e.what());
        return static_cast<int>(e.exitCode());
    }
}

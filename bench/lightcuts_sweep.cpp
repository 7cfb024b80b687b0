// Where Lightcuts starts paying off against brute force in the radiance bake's direct light: the
// measurement behind kLightcutsAutoLights (vox/many_lights.h). Imports a scene once, then for each
// light count N keeps the scene's first N static lights (its dynamic lights, which the bake leaves
// out, are dropped first; --spread takes N evenly spaced ones instead) and bakes it with no
// bounces, Lightcuts on and --lightcuts-compare, so every bake times all three methods on the same
// voxels: Lightcuts (forest, cluster–light lists, cut reuse), classic Lightcuts and brute force.
//
// Usage: lightcuts_sweep SCENE [--depth D=7] [--counts 4,8,16,...] [--repeat R=1] [--spread]
//                              [--threads T=0 (all)] [--json FILE]
//
// Columns (times in seconds; with --repeat R each is the median of R bakes, the machine being
// noisy; counts, cut sizes and errors are deterministic and come from the first bake):
//   lights     N, the static lights baked
//   points     voxels lit (render points)
//   lc_s       Lightcuts' direct light (ManyLightStats::seconds: cuts and visibility)
//   lc_all_s   lc_s + building the light forest + clustering the voxels (what Auto really costs)
//   brute_s    every light at every voxel
//   lc/brute   lc_s / brute_s           (< 1: Lightcuts is faster)
//   all/brute  lc_all_s / brute_s
//   classic_s  classic Lightcuts (one tree, no clusters, no cut reuse)
//   cut        Lightcuts' mean cut size
//   within2%   fraction of the lit voxels whose Lightcuts result is within 2 % of brute force
//   max_err    Lightcuts' largest relative error
// Last, the crossover: the smallest N from which Lightcuts is faster than brute force at that
// count and at every larger count measured, by lc_s and by lc_all_s.
#include <vox/base/error.h>
#include <vox/import.h>
#include <vox/radiance.h>
#include <vox/util/log.h>
#include <vox/util/parallel.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace {

double median(std::vector<double> values) {
    std::sort(values.begin(), values.end());
    const std::size_t n = values.size();
    return n == 0 ? 0.0 : n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

std::vector<std::size_t> parseCounts(const std::string& text) {
    std::vector<std::size_t> counts;
    std::stringstream in(text);
    std::string item;
    while (std::getline(in, item, ',')) {
        std::size_t used = 0;
        const unsigned long long n = std::stoull(item, &used);
        if (used != item.size() || n == 0)
            throw vox::UsageError("--counts: '" + item + "' is not a positive integer");
        counts.push_back(static_cast<std::size_t>(n));
    }
    if (counts.empty()) throw vox::UsageError("--counts needs at least one count");
    return counts;
}

struct Row {
    std::size_t lights = 0;
    std::uint64_t points = 0;
    double lc = 0, lcAll = 0, brute = 0, classic = 0, bake = 0;
    double cut = 0, classicCut = 0, within = 0, maxError = 0, classicWithin = 0;
};

/// The smallest count from which @p ratio is below 1 at that count and every larger one; none
/// when the largest count is not.
std::optional<std::size_t> crossover(const std::vector<Row>& rows, double (*ratio)(const Row&)) {
    std::optional<std::size_t> from;
    for (auto it = rows.rbegin(); it != rows.rend() && ratio(*it) < 1; ++it) from = it->lights;
    return from;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        const std::string usage =
            "usage: lightcuts_sweep SCENE [--depth D=7] [--counts 4,8,16,...] [--repeat R=1] "
            "[--spread] [--threads T] [--json FILE]";
        if (argc < 2 || std::string(argv[1]).starts_with("--")) throw vox::UsageError(usage);
        std::uint32_t depth = 7;
        std::vector<std::size_t> counts{4, 8, 16, 32, 64, 128, 256};
        int repeat = 1, threads = 0;
        bool spread = false;
        std::string jsonFile;
        for (int i = 2; i < argc; ++i) {
            const std::string key = argv[i];
            if (key == "--spread") {
                spread = true;
                continue;
            }
            if (i + 1 >= argc) throw vox::UsageError(usage);
            const std::string value = argv[++i];
            if (key == "--depth")
                depth = static_cast<std::uint32_t>(std::stoul(value));
            else if (key == "--counts")
                counts = parseCounts(value);
            else if (key == "--repeat")
                repeat = std::stoi(value);
            else if (key == "--threads")
                threads = std::stoi(value);
            else if (key == "--json")
                jsonFile = value;
            else
                throw vox::UsageError("unknown option " + key + "\n" + usage);
        }
        if (depth < 1 || depth > 10) throw vox::UsageError("--depth must be 1 … 10");
        if (repeat < 1) throw vox::UsageError("--repeat must be ≥ 1");
        const vox::ThreadLimit limit(threads);
        vox::log::setVerbosity(vox::log::Verbosity::Quiet);  // the benchmark's output is its table

        vox::Scene scene = vox::importScene(argv[1]);
        std::vector<vox::Light> all;
        for (const vox::Light& light : scene.lights)
            if (!light.dynamic) all.push_back(light);
        std::sort(counts.begin(), counts.end());
        counts.erase(std::unique(counts.begin(), counts.end()), counts.end());
        if (counts.back() > all.size()) {
            std::fprintf(stderr,
                         "lightcuts_sweep: %s has %zu static lights; larger counts are left out\n",
                         argv[1], all.size());
            while (!counts.empty() && counts.back() > all.size()) counts.pop_back();
            if (counts.empty() || counts.back() < all.size()) counts.push_back(all.size());
        }

        std::printf(
            "%s: depth %u, %zu static lights, %s lights of each count, %d thread(s), median of %d "
            "bake(s)\n",
            argv[1], depth, all.size(), spread ? "evenly spaced" : "first",
            vox::ThreadLimit::active(), repeat);
        std::printf("%7s %9s %9s %9s %9s %8s %9s %9s %7s %9s %9s\n", "lights", "points", "lc_s",
                    "lc_all_s", "brute_s", "lc/brute", "all/brute", "classic_s", "cut", "within2%",
                    "max_err");
        std::fflush(stdout);
        std::vector<Row> rows;
        nlohmann::json runs = nlohmann::json::array();
        for (const std::size_t n : counts) {
            scene.lights.clear();
            for (std::size_t k = 0; k < n; ++k)
                scene.lights.push_back(all[spread ? k * all.size() / n : k]);
            vox::RadianceBakeOptions options;
            options.depth = depth;
            options.bounces = 0;
            options.lightcuts = vox::LightcutsMode::On;
            options.lightcutsCompare = true;
            Row row;
            row.lights = n;
            std::vector<double> lc, lcAll, brute, classic, bake;
            for (int r = 0; r < repeat; ++r) {
                const auto start = std::chrono::steady_clock::now();
                const vox::RadianceBake result = vox::bakeRadiance(scene, options);
                bake.push_back(
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
                        .count());
                const vox::ManyLightReport& d = result.directLight;
                lc.push_back(d.lightcuts.seconds);
                lcAll.push_back(d.lightcuts.seconds + d.lightcuts.treeSeconds +
                                d.lightcuts.clusterSeconds);
                brute.push_back(d.bruteForce.seconds);
                classic.push_back(d.classic.seconds);
                if (r == 0) {
                    row.points = d.lightcuts.points;
                    row.cut = d.lightcuts.meanCutSize();
                    row.classicCut = d.classic.meanCutSize();
                    row.within = d.lightcutsError.fractionWithin();
                    row.maxError = d.lightcutsError.maxRelative;
                    row.classicWithin = d.classicError.fractionWithin();
                }
            }
            row.lc = median(lc);
            row.lcAll = median(lcAll);
            row.brute = median(brute);
            row.classic = median(classic);
            row.bake = median(bake);
            std::printf("%7zu %9llu %9.3f %9.3f %9.3f %8.2f %9.2f %9.3f %7.1f %9.4f %9.4f\n", n,
                        static_cast<unsigned long long>(row.points), row.lc, row.lcAll, row.brute,
                        row.brute > 0 ? row.lc / row.brute : 0.0,
                        row.brute > 0 ? row.lcAll / row.brute : 0.0, row.classic, row.cut,
                        row.within, row.maxError);
            std::fflush(stdout);
            runs.push_back({{"lights", n},
                            {"points", row.points},
                            {"lightcuts_seconds", lc},
                            {"lightcuts_total_seconds", lcAll},
                            {"brute_force_seconds", brute},
                            {"classic_seconds", classic},
                            {"bake_seconds", bake},
                            {"lightcuts_mean_cut_size", row.cut},
                            {"classic_mean_cut_size", row.classicCut},
                            {"lightcuts_fraction_within", row.within},
                            {"lightcuts_max_relative", row.maxError},
                            {"classic_fraction_within", row.classicWithin}});
            rows.push_back(row);
        }
        const auto describe = [](std::optional<std::size_t> n) {
            return n ? std::to_string(*n) + " lights" : std::string("none measured");
        };
        const auto byLc =
            crossover(rows, [](const Row& r) { return r.brute > 0 ? r.lc / r.brute : 2.0; });
        const auto byAll =
            crossover(rows, [](const Row& r) { return r.brute > 0 ? r.lcAll / r.brute : 2.0; });
        std::printf("crossover (Lightcuts faster from here on): %s by lc_s, %s by lc_all_s\n",
                    describe(byLc).c_str(), describe(byAll).c_str());
        if (!jsonFile.empty()) {
            const nlohmann::json out{
                {"scene", argv[1]},
                {"depth", depth},
                {"static_lights", all.size()},
                {"spread", spread},
                {"threads", vox::ThreadLimit::active()},
                {"repeat", repeat},
                {"runs", runs},
                {"crossover_lights", byLc ? nlohmann::json(*byLc) : nlohmann::json(nullptr)},
                {"crossover_lights_total",
                 byAll ? nlohmann::json(*byAll) : nlohmann::json(nullptr)}};
            std::ofstream file(jsonFile);
            file << out.dump(2) << '\n';
            if (!file) throw vox::IoError(jsonFile, "cannot write");
        }
        return 0;
    } catch (const vox::UsageError& e) {
        std::cerr << "lightcuts_sweep: " << e.what() << '\n';
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "lightcuts_sweep: error: " << e.what() << '\n';
        return 4;
    }
}

#include "esvo_commands.h"

#include "../common/camera_options.h"
#include "../common/reports.h"

#include <vox/base/channels.h>
#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>
#include <vox/image_io.h>
#include <vox/raycast.h>
#include <vox/util/log.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>

namespace vox::tools {
namespace {

void printInfo(const std::string& file, bool json) {
    const esvo::EsvoReader reader(file);
    const esvo::FileBreakdown breakdown = esvo::validateFile(reader);
    const nlohmann::json report = esvoReport(reader, breakdown);
    if (json) {
        std::cout << report.dump(2) << "\n";
        return;
    }
    std::printf("%s: .esvo %s, leaf depth %u\n", file.c_str(),
                report["version"].get<std::string>().c_str(), reader.header().leafDepth);
    std::printf("  voxels          %llu\n",
                static_cast<unsigned long long>(report["voxels"].get<std::uint64_t>()));
    const auto& perLevel = reader.directory().voxelsPerLevel;
    std::printf("    %-9s %14s %14s %14s\n", "", "voxels", "leaves", "contours");
    for (std::size_t l = 0; l < perLevel.size(); ++l)
        std::printf("    level %-3zu %14llu %14llu %14llu\n", l,
                    static_cast<unsigned long long>(perLevel[l]),
                    static_cast<unsigned long long>(breakdown.leavesPerLevel[l]),
                    static_cast<unsigned long long>(breakdown.contoursPerLevel[l]));
    std::printf("  leaves          %llu\n",
                static_cast<unsigned long long>(report["leaves"].get<std::uint64_t>()));
    std::printf(
        "  slices          %zu (largest %u bytes, limit %u)\n", reader.directory().slices.size(),
        report["largest_slice_bytes"].get<std::uint32_t>(), reader.header().sliceBytesLimit);
    std::printf("  far pointers    %llu\n",
                static_cast<unsigned long long>(report["far_pointers"].get<std::uint64_t>()));
    std::printf("  file bytes      %llu\n",
                static_cast<unsigned long long>(reader.header().fileBytes));
    std::printf("  bytes per voxel %.3f\n", report["bytes_per_voxel"]["total"].get<double>());
    if (report["contours"].get<bool>())
        std::printf(
            "  contours        %llu voxels (%.1f %%), %llu bytes (%.3f per voxel)\n",
            static_cast<unsigned long long>(report["contour_voxels"].get<std::uint64_t>()),
            100 * report["contour_voxel_share"].get<double>(),
            static_cast<unsigned long long>(report["bytes"]["contours"].get<std::uint64_t>()),
            report["bytes_per_voxel"]["contours"].get<double>());
    else
        std::printf("  contours        none\n");
    std::printf("  attributes      %s\n", report["attributes"].get<std::string>().c_str());
    for (const char* part : kEsvoByteParts)
        std::printf("    %-22s %.4f  (%llu bytes)\n", part,
                    report["bytes_per_voxel"][part].get<double>(),
                    static_cast<unsigned long long>(report["bytes"][part].get<std::uint64_t>()));
}

nlohmann::json sliceJson(const esvo::SliceEntry& s, std::uint32_t index) {
    return {
        {"index", index},
        {"file_offset", s.fileOffset},
        {"bytes", s.byteSize},
        {"checksum", s.checksum},
        {"parent", s.parent == esvo::kNoSlice ? nlohmann::json(nullptr) : nlohmann::json(s.parent)},
        {"first_child", s.firstChild},
        {"children", s.childCount},
        {"region_level", s.regionLevel},
        {"path_levels", s.pathLevels},
        {"region_path", s.regionPath},
        {"first_level", s.firstLevel},
        {"end_level", s.endLevel},
        {"first_frontier", s.firstFrontier},
        {"root_groups", s.rootGroupCount},
        {"descriptors", s.descriptorCount},
        {"far_pointers", s.farPointerCount},
        {"voxels", s.voxelCount}};
}

void dump(const std::string& file, long long sliceIndex, bool json) {
    const esvo::EsvoReader reader(file);
    const esvo::Header& h = reader.header();
    if (sliceIndex < 0) {
        if (json) {
            nlohmann::json out;
            out["header"] = {
                {"version", std::to_string(h.versionMajor) + "." + std::to_string(h.versionMinor)},
                {"world_to_root", h.worldToRoot},
                {"scene_bounds", {h.sceneBoundsMin, h.sceneBoundsMax}},
                {"leaf_depth", h.leafDepth},
                {"attachment_kinds", h.attachmentKinds},
                {"slice_bytes_limit", h.sliceBytesLimit},
                {"near_pointer_limit", h.nearPointerLimit},
                {"slice_count", h.sliceCount},
                {"directory_offset", h.directoryOffset},
                {"directory_bytes", h.directoryBytes},
                {"file_bytes", h.fileBytes}};
            out["voxels_per_level"] = reader.directory().voxelsPerLevel;
            nlohmann::json slices = nlohmann::json::array();
            for (std::uint32_t i = 0; i < reader.sliceCount(); ++i)
                slices.push_back(sliceJson(reader.slice(i), i));
            out["slices"] = slices;
            std::cout << out.dump(2) << "\n";
            return;
        }
        std::printf(
            "header: version %u.%u, leaf depth %u, %u slices, slice limit %u bytes, near pointer "
            "limit %u, %llu bytes\n",
            h.versionMajor, h.versionMinor, h.leafDepth, h.sliceCount, h.sliceBytesLimit,
            h.nearPointerLimit, static_cast<unsigned long long>(h.fileBytes));
        std::printf("%6s %6s %10s %8s %6s %9s %5s %7s %9s %9s %8s %10s\n", "slice", "parent",
                    "offset", "bytes", "region", "levels", "kids", "groups", "descr", "far",
                    "frontier", "voxels");
        for (std::uint32_t i = 0; i < reader.sliceCount(); ++i) {
            const esvo::SliceEntry& s = reader.slice(i);
            std::printf("%6u %6lld %10llu %8u %6u %4u-%-4u %5u %7u %9u %9u %8u %10llu\n", i,
                        s.parent == esvo::kNoSlice ? -1LL : static_cast<long long>(s.parent),
                        static_cast<unsigned long long>(s.fileOffset), s.byteSize, s.regionLevel,
                        s.firstLevel, s.endLevel, s.childCount, s.rootGroupCount, s.descriptorCount,
                        s.farPointerCount, s.firstFrontier,
                        static_cast<unsigned long long>(s.voxelCount));
        }
        return;
    }
    if (sliceIndex >= reader.sliceCount())
        throw UsageError("--slice " + std::to_string(sliceIndex) + ": the file has " +
                         std::to_string(reader.sliceCount()) + " slices");
    const auto index = static_cast<std::uint32_t>(sliceIndex);
    const std::vector<std::uint8_t> block = reader.readSlice(index);
    const esvo::BlockTables t =
        esvo::readBlockTables(block, reader.path(), index, reader.slice(index).fileOffset);
    // Every 8-byte unit of the descriptor area, classified by walking it in order.
    nlohmann::json units = nlohmann::json::array();
    if (!json) {
        std::printf(
            "slice %u: %zu bytes, info section at byte %u, %u root groups, %u frontier "
            "descriptors\n",
            index, block.size(), 4 * t.infoWord, t.rootGroupCount, t.frontierCount);
        std::printf("%8s  %-10s %s\n", "byte", "kind", "content");
    }
    const std::uint32_t descriptorUnits = t.descriptorEndWord / 2;
    std::vector<std::uint8_t> isSlot(descriptorUnits, 0);
    for (std::uint32_t u = 1; u < descriptorUnits; ++u) {
        if ((8 * u) % esvo::kPageBytes == 0) continue;
        const esvo::ChildDescriptor d{esvo::load<std::uint32_t>(block.data() + 8 * u), 0};
        if (d.validMask() != 0 && d.far() && u + d.childPointer() < isSlot.size())
            isSlot[u + d.childPointer()] = 1;
    }
    for (std::uint32_t u = 0; u < descriptorUnits; ++u) {
        const std::uint32_t w0 = esvo::load<std::uint32_t>(block.data() + 8 * u);
        const std::uint32_t w1 = esvo::load<std::uint32_t>(block.data() + 8 * u + 4);
        const esvo::ChildDescriptor d{w0, w1};
        std::string kind;
        nlohmann::json entry{{"byte", 8 * u}};
        if ((8 * u) % esvo::kPageBytes == 0) {
            kind = "page";
            entry["info_offset_words"] = static_cast<std::int32_t>(w0);
        } else if (isSlot[u]) {
            kind = "far";
            entry["offset_units"] = static_cast<std::int32_t>(w0);
        } else if (d.validMask() != 0) {
            kind = "descriptor";
            entry["valid"] = d.validMask();
            entry["non_leaf"] = d.nonLeafMask();
            entry["far"] = d.far();
            entry["child_pointer"] = d.childPointer();
            entry["contour_mask"] = d.contourMask();
            entry["contour_pointer"] = d.contourPointer();
        } else {
            kind = "padding";
        }
        entry["kind"] = kind;
        if (json) {
            units.push_back(entry);
            continue;
        }
        if (kind == "page")
            std::printf("%8u  %-10s info at %+d words\n", 8 * u, "page",
                        static_cast<std::int32_t>(w0));
        else if (kind == "far")
            std::printf("%8u  %-10s %+d units%s\n", 8 * u, "far", static_cast<std::int32_t>(w0),
                        w0 == 0 ? " (child slice not loaded)" : "");
        else if (kind == "descriptor")
            std::printf("%8u  %-10s valid %02x non-leaf %02x %s %u contours %02x at +%u words\n",
                        8 * u, "descriptor", d.validMask(), d.nonLeafMask(),
                        d.far() ? "far-slot" : "child", d.childPointer(), d.contourMask(),
                        d.contourPointer());
        else if (w0 || w1)
            std::printf("%8u  %-10s %08x %08x\n", 8 * u, "data?", w0, w1);
    }
    // The contour array, word by word, decoded.
    nlohmann::json contours = nlohmann::json::array();
    for (std::uint32_t w = t.contourWord; w < t.contourEndWord; ++w) {
        const std::uint32_t value = esvo::load<std::uint32_t>(block.data() + 4 * w);
        const esvo::Contour c = esvo::Contour::decode(value);
        if (json) {
            contours.push_back({{"byte", 4 * w},
                                {"normal", {c.nx, c.ny, c.nz}},
                                {"position", c.position},
                                {"thickness", c.thickness}});
            continue;
        }
        std::printf("%8u  %-10s n (%d %d %d) position %d thickness %u  (|n·u %+.2f| <= %.3f)\n",
                    4 * w, "contour", c.nx, c.ny, c.nz, c.position, c.thickness,
                    -c.position * esvo::Contour::kStep, 0.5 * c.thickness * esvo::Contour::kStep);
    }
    if (json) {
        nlohmann::json out = sliceJson(reader.slice(index), index);
        out["contour_byte"] = 4 * t.contourWord;
        out["contours"] = contours;
        out["info_byte"] = 4 * t.infoWord;
        std::vector<std::uint32_t> roots, frontier;
        for (std::uint32_t i = 0; i < t.rootGroupCount; ++i)
            roots.push_back(
                8 * esvo::load<std::uint32_t>(block.data() + 4 * (t.rootGroupTableWord + i)));
        for (std::uint32_t i = 0; i < t.frontierCount; ++i)
            frontier.push_back(
                8 * esvo::load<std::uint32_t>(block.data() + 4 * (t.frontierTableWord + i)));
        out["root_group_bytes"] = roots;
        out["frontier_bytes"] = frontier;
        out["units"] = units;
        std::cout << out.dump(1) << "\n";
    }
}

/// RenderBuffers as vox::composeChannel reads them; linear: the colour or shaded image.
struct BufferPixels {
    const RenderBuffers& image;
    const std::vector<Vec3f>& colours;

    [[nodiscard]] bool hit(std::size_t i) const { return std::isfinite(image.depth[i]); }
    [[nodiscard]] float depth(std::size_t i) const { return image.depth[i]; }
    [[nodiscard]] std::uint32_t iterations(std::size_t i) const { return image.iterations[i]; }
    [[nodiscard]] std::uint32_t level(std::size_t i) const { return image.level[i]; }
    [[nodiscard]] bool hasAttributes(std::size_t i) const { return vox::hasAttributes(image, i); }
    [[nodiscard]] Vec3f faceNormal(std::size_t i) const { return image.normal[i]; }
    [[nodiscard]] Vec3f shadingNormal(std::size_t i) const { return image.shadingNormal[i]; }
    [[nodiscard]] Vec3f linear(std::size_t i) const { return colours[i]; }
};

void render(const EsvoCommands& c) {
    const PinholeCamera camera = c.camera.camera();
    const Channel channel = parseChannel(c.channel);
    const bool colorChannel = isColorChannel(channel);
    if (c.filter && !colorChannel)
        throw UsageError("--filter applies to --channel color or shaded");
    if (!(c.lodScale >= 0)) throw UsageError("--lod-scale must be 0 or more");
    // The beam leaves every channel the same except iterations, which then counts the fine pass:
    // that one shows a single pass's work unless --beam asks otherwise.
    const int beam = c.beam != -1 ? c.beam : (channel == Channel::Iterations ? 0 : 8);
    if (beam != 0 && beam != 4 && beam != 8) throw UsageError("--beam must be 0, 4 or 8");

    const esvo::EsvoReader reader(c.file);
    esvo::EsvoPool pool(reader);
    pool.loadAll(c.loadLevels);
    const EsvoRayCaster caster(pool);
    CastOptions options;
    options.lodAngle = camera.pixelAngle() * c.lodScale;
    options.maxLevel = c.maxLevel;
    options.attributes = channelNeedsAttributes(channel);
    if (channel == Channel::Color && !reader.header().hasAttributes())
        throw UsageError(c.file + ": no colours in this file (voxelize --attributes none)");
    const RenderBuffers image = renderEsvo(caster, camera, options, beam);
    std::vector<Vec3f> linear;  // color / shaded
    if (colorChannel) {
        linear = channel == Channel::Color ? albedoImage(image) : shadeHeadlight(image, camera);
        if (c.filter)
            linear = postProcessFilter(linear, filterRadii(image, caster, camera), image.width,
                                       image.height);
    }

    const std::size_t pixels = image.depth.size();
    const std::vector<std::uint8_t> rgb =
        composeChannel(channel, pixels, BufferPixels{image, linear});
    writePng(c.output, image.width, image.height, 3, rgb);
    if (!c.depthOut.empty()) writePfm(c.depthOut, image.width, image.height, image.depth);
    const double rays = double(pixels);
    log::info(c.output + ": " + std::to_string(image.width) + "x" + std::to_string(image.height) +
              ", " + std::to_string(image.hits) + " hits, " +
              std::to_string(rays / image.seconds / 1e6) + " Mrays/s" +
              (beam ? " (beam " + std::to_string(beam) + ")" : std::string()));
    if (!c.stats.empty()) {
        nlohmann::json report{{"file", c.file},
                              {"width", image.width},
                              {"height", image.height},
                              {"rays", pixels},
                              {"hits", image.hits},
                              {"cast_seconds", image.seconds},
                              {"mrays_per_second", rays / image.seconds / 1e6},
                              {"loaded_slices", pool.loadedSliceCount()},
                              {"resident_bytes", pool.residentBytes()}};
        std::uint64_t iterations = 0;
        for (std::uint32_t it : image.iterations) iterations += it;
        report["mean_iterations"] = double(iterations) / rays;  // the fine pass's, per ray
        report["beam"] = beam;
        report["coarse_rays"] = image.coarseRays;
        report["coarse_iterations_per_pixel"] = double(image.coarseIterations) / rays;
        report["mean_iterations_with_coarse"] = double(iterations + image.coarseIterations) / rays;
        report["coarse_seconds"] = image.coarseSeconds;
        report["fine_seconds"] = image.seconds - image.coarseSeconds;
        Timings timings;
        timings.add("cast", image.seconds * 1000.0);
        if (beam) {
            timings.add("coarse", image.coarseSeconds * 1000.0);
            timings.add("fine", (image.seconds - image.coarseSeconds) * 1000.0);
        }
        writeStats(c.stats, report, "voxinspect render", timings);
    }
}

}  // namespace

void EsvoCommands::add(CLI::App& app) {
    info = app.add_subcommand("info",
                              "Levels, voxels per level, slices and bytes per voxel of an .esvo "
                              "file (or an .rvol file's levels)");
    info->add_option("file", file, ".esvo or .rvol file")->required();
    info->add_flag("--json", json, "Print JSON");

    validate = app.add_subcommand(
        "validate",
        "Check every invariant of an .esvo or .rvol file; exit 3 at the first violation");
    validate->add_option("file", file, ".esvo or .rvol file")->required();

    dump =
        app.add_subcommand("dump", "Print the header and slice directory, or one slice's blocks");
    dump->add_option("file", file, ".esvo file")->required();
    dump->add_option("--slice", slice, "Dump this slice's descriptor area unit by unit")
        ->check(CLI::NonNegativeNumber);
    dump->add_flag("--json", json, "Print JSON");

    render = app.add_subcommand(
        "render",
        "Ray cast an .esvo file to a PNG (and a PFM depth map), or final-gather an .rvol file");
    render->add_option("file", file, ".esvo or .rvol file")->required();
    render->add_option("-o,--output", output, "PNG to write")->required();
    camera.add(*render);
    render
        ->add_option("--channel", channel,
                     "shaded (headlight Phong on the voxels' colours and normals), color, normal "
                     "(shading normal), "
                     "face-normal (of the cube face or contour hit), depth, iterations or level; "
                     ".rvol: final (default), direct, "
                     "indirect, specular, ao, albedo or normal")
        ->capture_default_str();
    render->add_flag("--filter", filter,
                     "Post-process filter (Laine & Karras 6.3): blur each pixel over its voxel's "
                     "projected size");
    render->add_option("--depth-out", depthOut, "Write distances as PFM (+inf where rays miss)");
    render->add_option("--max-level", maxLevel, "Treat voxels of this level as leaves");
    render->add_option("--load-levels", loadLevels,
                       "Load only slices starting above this level (streaming check)");
    render
        ->add_option("--lod-scale", lodScale,
                     "Stop at voxels smaller than this many pixels; 0: always to the leaves")
        ->capture_default_str();
    render->add_option("--beam", beam,
                       "Beam optimisation: a coarse pass per NxN pixel block (0: off, 4 or 8; "
                       "default 8, 0 for --channel iterations); "
                       "the same image, faster");
    render->add_option("--stats", stats, "Write a JSON report: rays, Mrays/s, iterations");
}

bool EsvoCommands::run() {
    if (info->parsed()) {
        printInfo(file, json);
    } else if (validate->parsed()) {
        const esvo::EsvoReader reader(file);
        (void)esvo::validateFile(reader);
        log::info(file + ": valid (" + std::to_string(reader.sliceCount()) + " slices, " +
                  std::to_string(reader.header().fileBytes) + " bytes)");
    } else if (dump->parsed()) {
        vox::tools::dump(file, slice, json);
    } else if (render->parsed()) {
        vox::tools::render(*this);
    } else {
        return false;
    }
    return true;
}

}  // namespace vox::tools

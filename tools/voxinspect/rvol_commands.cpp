#include "rvol_commands.h"

#include "../common/camera_options.h"
#include "../common/reports.h"

#include <vox/final_gather.h>
#include <vox/base/error.h>
#include <vox/formats/esvo_reader.h>
#include <vox/formats/rvol_io.h>
#include <vox/formats/rvol_tiles.h>
#include <vox/image_io.h>
#include <vox/import.h>
#include <vox/radiance_field.h>
#include <vox/texture.h>
#include <vox/triangle_raycast.h>
#include <vox/util/log.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <system_error>

namespace vox::tools {
namespace {

constexpr std::array<const char*, 6> kChannelNames{"px", "nx", "py", "ny", "pz", "nz"};

const char* attenuationName(std::uint32_t attenuation) {
    switch (attenuation) {
        case 0:
            return "weighted";
        case 1:
            return "paper";
        case 2:
            return "average";
        case 3:
            return "adaptive";
        default:
            return "unknown";
    }
}

std::uint8_t toByte(float v) {
    return static_cast<std::uint8_t>(std::lround(255.0f * std::clamp(v, 0.0f, 1.0f)));
}

/// exposure × linear radiance, Reinhard x/(1 + x) per channel, sRGB-encoded to 8 bits.
std::uint8_t toneMap(double linear, double exposure) {
    const double x = std::max(0.0, exposure * linear);
    return toByte(linearToSrgb(static_cast<float>(x / (1 + x))));
}

void checkExposure(double exposure) {
    if (!(exposure > 0) || !std::isfinite(exposure))
        throw UsageError("--exposure must be a finite number > 0");
}

/// A tiled volume's reader with at most @p maxOpenTiles tile files open.
rvol::TiledRvolReaderOptions tiledOptions(unsigned maxOpenTiles) {
    rvol::TiledRvolReaderOptions options;
    options.maxOpenTiles = maxOpenTiles;
    return options;
}

void addMaxOpenTiles(CLI::App& command, unsigned& maxOpenTiles) {
    command
        .add_option("--max-open-tiles", maxOpenTiles,
                    "A tiled volume's index: tile files open at once (the least recently used is "
                    "closed, and opened again when needed)")
        ->check(CLI::Range(1u, 1u << 20))
        ->capture_default_str();
}

/// What a tiled volume's reader opened (null for a single file).
nlohmann::json openTilesReport(const rvol::RvolSampler& file) {
    const auto* tiled = dynamic_cast<const rvol::TiledRvolReader*>(&file);
    if (!tiled) return nullptr;
    const rvol::OpenTileStats stats = tiled->openTileStats();
    return {{"max_open_tiles", tiled->options().maxOpenTiles},
            {"most_open", stats.mostOpen},
            {"opened", stats.opened},
            {"closed", stats.closed}};
}

// ---- info, validate ------------------------------------------------------------------------

nlohmann::json rvolReport(const rvol::RvolReader& reader, const rvol::RvolReport& report,
                          const std::string& file) {
    const rvol::Header& h = reader.header();
    nlohmann::json levels = nlohmann::json::array();
    for (std::uint32_t l = 0; l < reader.levels().size(); ++l) {
        const rvol::LevelEntry& e = reader.level(l);
        levels.push_back(
            {{"level", l},
             {"resolution", e.resolution},
             {"channels", e.channels},
             {"cell_size", h.cellSize(l)},
             {"bricks_per_axis", e.bricksPerAxis},
             {"bricks", e.brickCount},
             {"dense_brick_bytes", e.denseBrickBytes},
             {"bytes", e.dataBytes},
             {"cells",
              l < report.nonZeroTexelsPerLevel.size() ? report.nonZeroTexelsPerLevel[l] : 0}});
    }
    return {{"file", file},
            {"version", std::to_string(h.versionMajor) + "." + std::to_string(h.versionMinor)},
            {"depth", h.depth},
            {"resolution", rvol::levelResolution(h.depth, 0)},
            {"brick_texels", h.brickTexels},
            {"root_cube", {{"origin", h.origin}, {"size", h.size}}},
            {"cell_size", h.cellSize(0)},
            {"scene_bounds",
             {{"min", {h.sceneBounds[0], h.sceneBounds[1], h.sceneBounds[2]}},
              {"max", {h.sceneBounds[3], h.sceneBounds[4], h.sceneBounds[5]}}}},
            {"bake",
             {{"bounces", h.bake.bounces},
              {"bounce_gather", h.bake.gatherRays > 0 ? "rays" : "cones"},
              {"gather_rays", h.bake.gatherRays},
              {"attenuation", attenuationName(h.bake.attenuation)},
              {"shadow_aperture_degrees", h.bake.shadowApertureDegrees},
              {"ao_lambda", h.bake.aoLambda},
              {"lights", h.bake.lights}}},
            {"levels", levels},
            {"bricks", h.brickCount},
            {"static_attributes", (h.flags & rvol::kFlagStaticAttributes) != 0},
            {"static_voxels", h.staticVoxelCount},
            {"dynamic_voxels", h.dynamicVoxelCount},
            {"file_bytes", h.fileBytes},
            {"bytes",
             {{"header", report.headerBytes},
              {"level_table", report.levelTableBytes},
              {"directory", report.directoryBytes},
              {"radiance", report.radianceBytes},
              {"static_attributes", report.staticAttributeBytes},
              {"dynamic_attributes", report.dynamicAttributeBytes},
              {"padding", report.paddingBytes}}}};
}

void printTiledInfo(const std::string& file, bool json);

void printInfo(const std::string& file, bool json) {
    if (rvol::isTileIndex(file)) return printTiledInfo(file, json);
    const rvol::RvolReader reader(file);
    const rvol::RvolReport validated = rvol::validateRvol(reader);
    const nlohmann::json report = rvolReport(reader, validated, file);
    if (json) {
        std::cout << report.dump(2) << "\n";
        return;
    }
    const rvol::Header& h = reader.header();
    const auto u64 = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
    std::printf("%s: .rvol %u.%u, depth %u (%u cells per axis), %u-texel bricks\n", file.c_str(),
                h.versionMajor, h.versionMinor, h.depth, rvol::levelResolution(h.depth, 0),
                h.brickTexels);
    std::printf("  root cube       origin (%g, %g, %g), size %g (level-0 cell %g)\n", h.origin[0],
                h.origin[1], h.origin[2], h.size, h.cellSize(0));
    std::printf("  scene bounds    [%g, %g, %g] - [%g, %g, %g]\n", h.sceneBounds[0],
                h.sceneBounds[1], h.sceneBounds[2], h.sceneBounds[3], h.sceneBounds[4],
                h.sceneBounds[5]);
    char shadows[64];
    if (h.bake.shadowApertureDegrees > 0)
        std::snprintf(shadows, sizeof shadows, "shadow cones %g°",
                      double(h.bake.shadowApertureDegrees));
    else
        std::snprintf(shadows, sizeof shadows, "shadow rays");
    char gather[64];
    if (h.bake.gatherRays > 0)
        std::snprintf(gather, sizeof gather, "gathered by %u rays per voxel", h.bake.gatherRays);
    else
        std::snprintf(gather, sizeof gather, "gathered by cones");
    std::printf("  bake            %u bounces %s, attenuation %s, %s, AO lambda %g, %u lights\n",
                h.bake.bounces, gather, attenuationName(h.bake.attenuation), shadows,
                double(h.bake.aoLambda), h.bake.lights);
    std::printf(
        "  voxels          %llu static, %llu dynamic%s\n", u64(h.staticVoxelCount),
        u64(h.dynamicVoxelCount),
        (h.flags & rvol::kFlagStaticAttributes) ? "" : " (static attribute layer not written)");
    std::printf("  %-6s %10s %8s %8s %12s %10s\n", "level", "resolution", "channels", "bricks",
                "bytes", "cells");
    for (const auto& level : report["levels"])
        std::printf("  %-6u %10u %8u %8u %12llu %10llu\n", level["level"].get<unsigned>(),
                    level["resolution"].get<unsigned>(), level["channels"].get<unsigned>(),
                    level["bricks"].get<unsigned>(), u64(level["bytes"].get<std::uint64_t>()),
                    u64(level["cells"].get<std::uint64_t>()));
    std::printf("  bricks          %llu\n", u64(h.brickCount));
    std::printf("  file bytes      %llu\n", u64(h.fileBytes));
    for (const char* part : {"header", "level_table", "directory", "radiance", "static_attributes",
                             "dynamic_attributes", "padding"})
        std::printf("    %-20s %12llu\n", part, u64(report["bytes"][part].get<std::uint64_t>()));
}

// ---- tiled volumes (a tile index, its tiles and far field) -------------------------------------

void printTiledInfo(const std::string& file, bool json) {
    const rvol::TileIndex index = rvol::readTileIndex(file);
    std::uint64_t voxels = 0, bytes = 0, bricks = 0;
    for (const rvol::TileEntry& t : index.tiles) {
        voxels += t.staticVoxels;
        bytes += t.fileBytes;
        bricks += t.bricks;
    }
    const std::uint64_t indexBytes =
        rvol::kTileIndexHeaderBytes + index.tiles.size() * rvol::kTileEntryBytes;
    if (json) {
        nlohmann::json out{
            {"file", file},
            {"kind", "tile index"},
            {"version",
             std::to_string(index.versionMajor) + "." + std::to_string(index.versionMinor)},
            {"depth", index.depth},
            {"resolution", 1ull << index.depth},
            {"tile_depth", index.tileDepth},
            {"halo", index.halo},
            {"far_depth", index.farDepth},
            {"brick_texels", index.brickTexels},
            {"origin", index.origin},
            {"size", index.size},
            {"tiles", index.tiles.size()},
            {"static_voxels", voxels},
            {"bricks", bricks},
            {"bounces", index.bake.bounces},
            {"bytes", {{"index", indexBytes}, {"tiles", bytes}, {"far", index.farFileBytes}}}};
        std::cout << out.dump(2) << "\n";
        return;
    }
    std::printf("%s: tiled radiance volume, tile index %u.%u\n", file.c_str(), index.versionMajor,
                index.versionMinor);
    std::printf("  depth           %u (%llu cells per axis)\n", index.depth,
                static_cast<unsigned long long>(1ull << index.depth));
    std::printf("  tiles           %zu of 2^%u cells per axis, halo %u, far field depth %u\n",
                index.tiles.size(), index.tileDepth, index.halo, index.farDepth);
    std::printf("  root cube       origin (%g, %g, %g), size %g\n", index.origin[0],
                index.origin[1], index.origin[2], index.size);
    std::printf("  static voxels   %llu\n  bricks          %llu\n",
                static_cast<unsigned long long>(voxels), static_cast<unsigned long long>(bricks));
    std::printf("  bytes           index %llu, tiles %llu, far field %llu\n",
                static_cast<unsigned long long>(indexBytes), static_cast<unsigned long long>(bytes),
                static_cast<unsigned long long>(index.farFileBytes));
}

void validateTiled(const std::string& file) {
    const rvol::TiledRvolReport report = rvol::validateTiledRvol(file);
    if (log::verbosity() == log::Verbosity::Quiet) return;
    std::printf(
        "%s: valid tiled .rvol (%llu tiles, %llu bricks, %llu static voxels, %llu bytes "
        "of tiles, %llu of far field)\n",
        file.c_str(), static_cast<unsigned long long>(report.tiles),
        static_cast<unsigned long long>(report.bricks),
        static_cast<unsigned long long>(report.staticVoxels),
        static_cast<unsigned long long>(report.tileBytes),
        static_cast<unsigned long long>(report.farBytes));
}

void validate(const std::string& file) {
    if (rvol::isTileIndex(file)) return validateTiled(file);
    const rvol::RvolReader reader(file);
    const rvol::RvolReport report = rvol::validateRvol(reader);
    if (log::verbosity() == log::Verbosity::Quiet) return;
    std::printf(
        "%s: valid .rvol (depth %u, %llu bricks, %llu static + %llu dynamic voxels, %llu bytes)\n",
        file.c_str(), reader.header().depth, static_cast<unsigned long long>(report.bricks),
        static_cast<unsigned long long>(report.staticVoxels),
        static_cast<unsigned long long>(report.dynamicVoxels),
        static_cast<unsigned long long>(report.fileBytes));
}

// ---- sample --------------------------------------------------------------------------------

Vec3d parseDirection(const std::string& text) {
    static const std::array<std::pair<const char*, Vec3d>, 6> kAxes{{{"+x", {1, 0, 0}},
                                                                     {"-x", {-1, 0, 0}},
                                                                     {"+y", {0, 1, 0}},
                                                                     {"-y", {0, -1, 0}},
                                                                     {"+z", {0, 0, 1}},
                                                                     {"-z", {0, 0, -1}}}};
    for (const auto& [name, v] : kAxes)
        if (text == name) return v;
    if (text.find(',') == std::string::npos)
        throw UsageError("--dir expects +x, -x, +y, -y, +z, -z or dx,dy,dz (got '" + text + "')");
    const Vec3d d = parseVector(text, "--dir");
    if (!(length(d) > 0)) throw UsageError("--dir must not be the zero vector");
    return normalize(d);
}

void sample(const RvolCommands& c) {
    const Vec3d at = parseVector(c.at, "--at");
    const bool hasDir = !c.dir.empty();
    const Vec3d dir = hasDir ? parseDirection(c.dir) : Vec3d{0, 0, 0};
    const std::unique_ptr<rvol::RvolSampler> file =
        rvol::openRvolSampler(c.file, tiledOptions(c.maxOpenTiles));
    const rvol::RvolSampler& reader = *file;
    const std::uint32_t depth = reader.depth();
    if (c.level < 0 || static_cast<std::uint32_t>(c.level) > depth)
        throw UsageError("--level " + std::to_string(c.level) + ": " + c.file +
                         " has levels 0 to " + std::to_string(depth));
    const auto level = static_cast<std::uint32_t>(c.level);
    const std::array<double, 3> p{at.x, at.y, at.z};
    rvol::Texel t;
    std::string what;
    if (level == 0) {
        t = reader.sample(0, 0, p);
        what = "isotropic";
    } else if (hasDir) {
        t = reader.sampleDirectional(level, p, {dir.x, dir.y, dir.z});
        what = "directional";
    } else {
        for (std::uint32_t k = 0; k < rvol::kDirections; ++k) {
            const rvol::Texel s = reader.sample(level, k, p);
            t.r += s.r / 6, t.g += s.g / 6, t.b += s.b / 6, t.a += s.a / 6;
        }
        what = "mean of 6 channels";
    }
    const std::array<double, 3> premultiplied{t.r, t.g, t.b};
    std::array<double, 3> radiance{0, 0, 0};
    if (t.a > 0)
        for (int k = 0; k < 3; ++k)
            radiance[static_cast<std::size_t>(k)] =
                premultiplied[static_cast<std::size_t>(k)] / t.a;
    if (c.json) {
        nlohmann::json out{
            {"radiance", radiance},
            {"occlusion", t.a},
            {"premultiplied", premultiplied},
            {"level", level},
            {"position", {at.x, at.y, at.z}},
            {"direction", hasDir ? nlohmann::json({dir.x, dir.y, dir.z}) : nlohmann::json(nullptr)},
            {"channel", what}};
        std::cout << out.dump(2) << "\n";
        return;
    }
    std::printf("%s: level %u at (%g, %g, %g), %s", c.file.c_str(), level, at.x, at.y, at.z,
                what.c_str());
    if (hasDir) std::printf(" along (%g, %g, %g)", dir.x, dir.y, dir.z);
    std::printf("\n  radiance       %g %g %g\n  occlusion      %g\n  premultiplied  %g %g %g\n",
                radiance[0], radiance[1], radiance[2], double(t.a), premultiplied[0],
                premultiplied[1], premultiplied[2]);
}

// ---- slices --------------------------------------------------------------------------------

void slices(const RvolCommands& c) {
    checkExposure(c.exposure);
    if (c.axis != "x" && c.axis != "y" && c.axis != "z")
        throw UsageError("--axis must be x, y or z");
    const rvol::RvolReader reader(c.file);
    const std::uint32_t depth = reader.header().depth;
    const std::uint32_t resolution0 = rvol::levelResolution(depth, 0);
    if (c.index < 0 && c.slices->get_option("--index")->count() > 0)
        throw UsageError("--index must be 0 or more");
    if (c.index >= static_cast<long long>(resolution0))
        throw UsageError("--index " + std::to_string(c.index) + ": level 0 has cells 0 to " +
                         std::to_string(resolution0 - 1));
    const std::uint32_t index0 =
        c.index < 0 ? resolution0 / 2 : static_cast<std::uint32_t>(c.index);
    const rvol::Volume volume = reader.readVolume();
    const std::filesystem::path dir(c.outputDir);
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw IoError(dir, "cannot create the directory: " + ec.message());
    const int axis = c.axis[0] - 'x';
    std::size_t written = 0;
    for (std::uint32_t l = 0; l <= depth; ++l) {
        const rvol::Level& level = volume.levels[l];
        const std::uint32_t r = level.resolution;
        const std::uint32_t k = index0 >> l;  // the same world plane at every level
        for (std::uint32_t channel = 0; channel < level.channels; ++channel) {
            std::vector<std::uint8_t> rgb(3 * std::size_t{r} * r);
            for (std::uint32_t row = 0; row < r; ++row)
                for (std::uint32_t col = 0; col < r; ++col) {
                    // Seen from the positive end of the axis: z and x with +y up (x: +x right; z:
                    // −z right), y with −z up and +x right.
                    std::uint32_t x = 0, y = 0, z = 0;
                    if (axis == 2)
                        x = col, y = r - 1 - row, z = k;
                    else if (axis == 0)
                        x = k, y = r - 1 - row, z = r - 1 - col;
                    else
                        x = col, y = k, z = row;
                    const rvol::Texel t = level.at(x, y, z, channel);
                    std::uint8_t* px = &rgb[3 * (std::size_t{row} * r + col)];
                    px[0] = toneMap(t.r, c.exposure);
                    px[1] = toneMap(t.g, c.exposure);
                    px[2] = toneMap(t.b, c.exposure);
                }
            char name[32];
            std::snprintf(name, sizeof name, "L%u_%s.png", l,
                          l == 0 ? "iso" : kChannelNames[channel]);
            writePng(dir / name, static_cast<int>(r), static_cast<int>(r), 3, rgb);
            ++written;
        }
    }
    log::info(c.outputDir + ": " + std::to_string(written) + " slices along " + c.axis +
              " through level-0 cell " + std::to_string(index0));
}

// ---- render --------------------------------------------------------------------------------

void render(const RvolCommands& r, const EsvoCommands& c) {
    const PinholeCamera camera = c.camera.camera();
    const bool channelGiven = c.render->get_option("--channel")->count() > 0;
    const std::string channel = channelGiven ? c.channel : "final";
    static const std::array<std::string, 7> kChannels{"final", "direct", "indirect", "specular",
                                                      "ao",    "albedo", "normal"};
    if (std::find(kChannels.begin(), kChannels.end(), channel) == kChannels.end())
        throw UsageError(
            "--channel for an .rvol file must be final, direct, indirect, specular, ao, albedo or "
            "normal");
    checkExposure(r.exposure);
    if (r.scene.empty() && r.esvo.empty())
        throw UsageError("render " + c.file +
                         " needs --scene SCENE or --esvo FILE.esvo for the primary hits");

    // One file is read whole, so that the cones look texels up without locks; a tiled volume
    // (larger than memory, by design) is sampled from its files as the cones reach them.
    const std::unique_ptr<rvol::RvolSampler> file =
        rvol::openRvolSampler(c.file, tiledOptions(r.maxOpenTiles));
    const auto* single = dynamic_cast<const rvol::RvolReader*>(file.get());
    const rvol::Volume volume = single ? single->readVolume() : rvol::Volume{};
    const RadianceField field = single ? RadianceField(volume) : RadianceField(*file);
    const rvol::BakeInfo& bake = file->bakeInfo();
    FinalGatherOptions options;
    options.specularApertureDegrees = r.specAperture;
    options.shadowApertureDegrees = r.shadowAperture;
    options.shadowCones = !r.noShadowCones;
    options.aoLambda = bake.aoLambda;
    options.lightcuts = parseLightcutsMode(r.lightcuts);
    options.lightcut.relativeError = r.lightcutError;
    options.lightcut.criterion = parseLightcutCriterion(r.lightcutCriterion);
    options.lightcut.maxCutSize = r.lightcutMaxCut;
    options.lightcutsCompare = r.lightcutsCompare;

    Scene scene;
    if (!r.scene.empty()) scene = importScene(r.scene);
    const FinalGather gather(field, scene.lights, options);
    if (r.scene.empty()) {
        if (bake.lights > 0)
            log::warning(r.esvo +
                         ": no lights without --scene: the direct term is 0 (the bake had " +
                         std::to_string(bake.lights) + ")");
    } else if (gather.staticLightCount() != bake.lights) {
        log::warning(r.scene + ": " + std::to_string(gather.staticLightCount()) +
                     " static lights, but " + c.file + " was baked with " +
                     std::to_string(bake.lights));
    }

    FinalGatherImage image;
    if (!r.esvo.empty()) {
        const esvo::EsvoReader esvoReader(r.esvo);
        esvo::EsvoPool pool(esvoReader);
        pool.loadAll();
        const EsvoRayCaster caster(pool);
        CastOptions cast;
        cast.lodAngle = camera.pixelAngle();
        cast.attributes = true;
        image = renderFinalGather(gather, camera, [&](const Ray& ray, ShadingPoint& out) {
            return esvoShadingPoint(caster, ray, cast, out);
        });
    } else {
        const TriangleRayCaster caster(scene);  // static meshes: what the volume holds
        const double footprint = camera.pixelAngle();
        image = renderFinalGather(gather, camera, [&](const Ray& ray, ShadingPoint& out) {
            return sceneShadingPoint(scene, caster, ray, footprint, out);
        });
    }

    const std::size_t pixels = image.hit.size();
    std::vector<std::uint8_t> rgb(3 * pixels, 0);
    const std::vector<Vec3f>* radiance = channel == "final"      ? &image.final
                                         : channel == "direct"   ? &image.direct
                                         : channel == "indirect" ? &image.indirect
                                         : channel == "specular" ? &image.specular
                                                                 : nullptr;
    for (std::size_t i = 0; i < pixels; ++i) {
        if (!image.hit[i]) continue;
        std::uint8_t* p = &rgb[3 * i];
        if (radiance) {
            for (int k = 0; k < 3; ++k) p[k] = toneMap((*radiance)[i][k], r.exposure);
        } else if (channel == "ao") {
            p[0] = p[1] = p[2] = toByte(image.ao[i]);
        } else if (channel == "albedo") {
            for (int k = 0; k < 3; ++k)
                p[k] = toByte(linearToSrgb(std::clamp(image.albedo[i][k], 0.0f, 1.0f)));
        } else {
            for (int k = 0; k < 3; ++k) p[k] = toByte(0.5f * (image.normal[i][k] + 1));
        }
    }
    writePng(c.output, image.width, image.height, 3, rgb);
    log::info(c.output + ": " + std::to_string(image.width) + "x" + std::to_string(image.height) +
              ", " + std::to_string(image.hits) + " hits, " + std::to_string(gather.lightCount()) +
              " lights (" + image.directLight.used.method + "), " + std::to_string(image.seconds) +
              " s");
    if (!c.stats.empty()) {
        const nlohmann::json report{
            {"file", c.file},
            {"width", image.width},
            {"height", image.height},
            {"hits", image.hits},
            {"seconds", image.seconds},
            {"direct_seconds", image.directSeconds},
            {"direct_light", directLightReport(image.directLight, options.lightcut)},
            {"open_tiles", openTilesReport(*file)}};
        Timings timings;
        timings.add("render", image.seconds * 1000.0);
        timings.add("direct", image.directSeconds * 1000.0);
        writeStats(c.stats, report, "voxinspect render", timings);
    }
}

/// The first of @p names that was given on @p command, or null.
const char* firstGiven(const CLI::App& command, std::initializer_list<const char*> names) {
    for (const char* name : names)
        if (command.get_option(name)->count() > 0) return name;
    return nullptr;
}

}  // namespace

bool isRvolFile(const std::string& file) {
    return std::filesystem::path(file).extension() == ".rvol";
}

void RvolCommands::add(CLI::App& app, EsvoCommands& esvoCommands) {
    shared = &esvoCommands;
    sample = app.add_subcommand("sample", "Sample an .rvol file's radiance and opacity at a point");
    sample->add_option("file", file, ".rvol file")->required();
    sample->add_option("--at", at, "World position x,y,z")->required();
    sample->add_option("--level", level, "Level: 0 (isotropic) to the file's depth")
        ->capture_default_str();
    sample->add_option(
        "--dir", dir,
        "Direction a cone looks along (levels >= 1): +x, -x, +y, -y, +z, -z or dx,dy,dz");
    sample->add_flag("--json", json, "Print JSON");
    addMaxOpenTiles(*sample, maxOpenTiles);

    slices = app.add_subcommand(
        "slices",
        "Write one PNG per level and channel of an .rvol file: a slice through the volume");
    slices->add_option("file", file, ".rvol file")->required();
    slices->add_option("-o,--output", outputDir, "Directory to write L<level>_<channel>.png into")
        ->required();
    slices->add_option("--axis", axis, "Axis the slices are perpendicular to: x, y or z")
        ->capture_default_str();
    slices->add_option("--index", index, "Level-0 cell index along the axis (default: the middle)");
    slices->add_option("--exposure", exposure, "Radiance scale before tone mapping")
        ->capture_default_str();

    CLI::App& render = *esvoCommands.render;
    render.add_option("--scene", scene,
                      ".rvol: primary hits (and lights) from this scene's static triangles");
    render.add_option("--esvo", esvo,
                      ".rvol: primary hits from this .esvo octree (lights only with --scene)");
    render.add_option("--exposure", exposure, ".rvol: radiance scale before tone mapping")
        ->capture_default_str();
    render.add_option("--spec-aperture", specAperture, ".rvol: specular cone aperture, degrees")
        ->capture_default_str();
    render.add_option("--shadow-aperture", shadowAperture, ".rvol: shadow cone aperture, degrees")
        ->capture_default_str();
    render.add_flag("--no-shadow-cones", noShadowCones, ".rvol: lights unshadowed");
    addMaxOpenTiles(render, maxOpenTiles);
    render
        .add_option("--lightcuts", lightcuts,
                    ".rvol: direct light through Lightcuts: on, off or auto (on from " +
                        std::to_string(kLightcutsAutoLights) + " lights)")
        ->check(CLI::IsMember({"auto", "on", "off"}))
        ->capture_default_str();
    render
        .add_option("--lightcut-error", lightcutError, ".rvol: Lightcuts' relative error per pixel")
        ->check(CLI::Range(0.0001, 1.0))
        ->capture_default_str();
    render
        .add_option("--lightcut-criterion", lightcutCriterion,
                    ".rvol: Lightcuts' error criterion: rss, sum or per-node")
        ->check(CLI::IsMember({"rss", "sum", "per-node"}))
        ->capture_default_str();
    render.add_option("--lightcut-max-cut", lightcutMaxCut, ".rvol: most clusters in one cut")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    render.add_flag("--lightcuts-compare", lightcutsCompare,
                    ".rvol: also light every pixel with classic Lightcuts and brute force; "
                    "compared in --stats");
}

bool RvolCommands::run() {
    EsvoCommands& c = *shared;
    if (sample->parsed()) {
        if (!isRvolFile(file)) throw UsageError("sample works on .rvol files (got '" + file + "')");
        vox::tools::sample(*this);
        return true;
    }
    if (slices->parsed()) {
        if (!isRvolFile(file)) throw UsageError("slices works on .rvol files (got '" + file + "')");
        vox::tools::slices(*this);
        return true;
    }
    const bool rvolFile = isRvolFile(c.file);
    if (c.render->parsed()) {
        if (rvolFile) {
            if (const char* option =
                    firstGiven(*c.render, {"--filter", "--depth-out", "--max-level",
                                           "--load-levels", "--lod-scale", "--beam"}))
                throw UsageError(std::string(option) + " applies to .esvo files");
        } else if (const char* option = firstGiven(
                       *c.render, {"--scene", "--esvo", "--exposure", "--spec-aperture",
                                   "--shadow-aperture", "--no-shadow-cones", "--lightcuts",
                                   "--lightcut-error", "--lightcut-criterion", "--lightcut-max-cut",
                                   "--lightcuts-compare", "--max-open-tiles"})) {
            throw UsageError(std::string(option) + " applies to .rvol files");
        }
    }
    if (!rvolFile) return false;
    if (c.info->parsed())
        printInfo(c.file, c.json);
    else if (c.validate->parsed())
        validate(c.file);
    else if (c.render->parsed())
        render(*this, c);
    else if (c.dump->parsed())
        throw UsageError(
            "dump works on .esvo files (info shows an .rvol file's header and levels)");
    else
        return false;
    return true;
}

}  // namespace vox::tools

// The compressed attribute block encoders (libvox/src/octree/attribute_encode.h) on a corpus:
// colour quality (PSNR of 8-bit sRGB RGB over the used slots, decoded by esvo::colorPalette)
// and speed against stb_dxt (normal and high-quality modes) on 4×4 tiles of real textures, whole
// and with 8 of 16 slots used; normal angular error and speed on analytic sphere patches, a
// bumpy height field and random cones. Prints JSON.
// With --scene, the corpus is instead the real blocks of a voxelized scene: the children of each
// pair of sibling descriptors, paired as writeEsvo pairs them, colours and normals as the
// uncompressed attachment stores them — so the PSNR is that of compressed against raw values.
// --dump FILE also writes those blocks (the 16 uncompressed 64-bit values and the used mask of
// each) to FILE, and --blocks FILE measures on such a file without voxelizing again (--stride K:
// every K-th block only, for profiling under callgrind). Times are the thread's CPU time (the
// best of three runs), so that other processes on a shared machine count less.
// --effort fast|default|best picks the encoders' AttributeEffort (default: default).
// --kernels sse2 runs the normal encoder's SSE2 kernels where the CPU has AVX-512 (whose are the
// default there; the blocks are the same bits, only the time differs); the JSON says which ran.
// Usage: attribute_encode_bench [--effort E] [TILES_PER_TEXTURE (default 4000)] [NORMAL_BLOCKS
// (default 20000)]
//        attribute_encode_bench [--effort E] --scene FILE [--depth N (default 10)] [--dump FILE]
//        attribute_encode_bench [--effort E] --blocks FILE [--stride K (default 1)]
#include "attribute_corpus.h"
#include "octree/attribute_encode.h"

#include <vox/base/error.h>
#include <vox/formats/esvo_attributes.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/util/log.h>
#include <vox/texture.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace {

namespace esvo = vox::esvo;
using esvo::Vec3;

/// The calling thread's CPU time in seconds: unlike wall time, it does not count the time the
/// thread waits for a core on a busy machine.
double threadSeconds() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

using vox::corpus::ColorBlock;
using vox::detail::AttributeEffort;

/// The effort every encoder call here uses (--effort).
AttributeEffort g_effort = AttributeEffort::Default;

const char* effortName(AttributeEffort e) {
    return e == AttributeEffort::Fast ? "fast" : e == AttributeEffort::Best ? "best" : "default";
}
using vox::corpus::normalised;
using vox::corpus::randomDirection;
using vox::corpus::randomMask;

struct NormalBlock {
    std::array<Vec3, 16> normals{};
    std::uint32_t mask = 0xFFFFu;
};

/// 4×4 tiles of ten assimp-testmodels textures.
std::vector<ColorBlock> textureTiles(std::size_t perTexture, std::vector<std::string>& used) {
    const std::filesystem::path models = "/usr/share/assimp/models";
    const std::vector<std::filesystem::path> files{
        models / "glTF/CesiumMilkTruck/CesiumMilkTruck.png",
        models / "OBJ/drkwood2.jpg",
        models / "IQM/Head.jpg",
        models / "IQM/Body.jpg",
        models / "3DS/CWALL02.jpg",
        models / "3DS/IMAGE2.jpg",
        models / "LWO/LWO2/MappingModes/earthSpherical.jpg",
        models / "ReferenceImages/MappingModes/spherical.png",
        models / "Ogre/TheThing/Wrinkles.jpg",
        models / "IRRMesh/brownground_1-1.jpg"};
    return vox::corpus::textureTiles(files, perTexture, &used);
}

/// Encodes every block with @p encode (best time of @p repeat runs); returns PSNR and µs/block.
template <typename Encode>
nlohmann::json colorRun(const std::vector<ColorBlock>& blocks, int repeat, Encode encode) {
    std::vector<std::array<std::uint32_t, 2>> words(blocks.size());
    double best = 1e30;
    for (int r = 0; r < repeat; ++r) {
        const double start = threadSeconds();
        for (std::size_t i = 0; i < blocks.size(); ++i) words[i] = encode(blocks[i]);
        best = std::min(best, threadSeconds() - start);
    }
    std::uint64_t error = 0, samples = 0;
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        error += vox::detail::colorBlockError(blocks[i].colors, blocks[i].mask, words[i][0],
                                              words[i][1]);
        samples += 3u * static_cast<unsigned>(std::popcount(blocks[i].mask & 0xFFFFu));
    }
    const double mse = static_cast<double>(error) / static_cast<double>(samples);
    return {{"psnr_db", mse > 0 ? 10 * std::log10(255.0 * 255.0 / mse) : 99.0},
            {"mse", mse},
            {"us_per_block", 1e6 * best / static_cast<double>(blocks.size())}};
}

nlohmann::json colorSuite(const std::vector<ColorBlock>& blocks) {
    return {
        {"blocks", blocks.size()},
        {"ours", colorRun(blocks, 3,
                          [](const ColorBlock& b) {
                              return vox::detail::encodeColorBlock(b.colors, b.mask, g_effort);
                          })},
        {"stb_normal",
         colorRun(blocks, 3, [](const ColorBlock& b) { return vox::corpus::stbEncode(b, false); })},
        {"stb_highqual",
         colorRun(blocks, 3, [](const ColorBlock& b) { return vox::corpus::stbEncode(b, true); })}};
}

// ---- normals ------------------------------------------------------------------------------------

/// Voxel-centre offsets of the 16 slots: two 2×2×2 descriptors side by side along @p longAxis.
std::array<std::array<double, 3>, 16> slotOffsets(unsigned longAxis) {
    std::array<std::array<double, 3>, 16> offsets{};
    for (unsigned s = 0; s < 16; ++s) {
        const unsigned child = s & 7, descriptor = s >> 3;
        offsets[s] = {(child & 1) - 0.5, ((child >> 1) & 1) - 0.5, ((child >> 2) & 1) - 0.5};
        offsets[s][longAxis] += 2.0 * descriptor - 1.0;
    }
    return offsets;
}

/// Sphere of @p radius voxels: slots whose voxel the surface crosses (at least one), normals
/// radial at the voxel centres; @p allSlots uses every slot instead.
std::vector<NormalBlock> spherePatches(std::mt19937& rng, std::size_t count, double radius,
                                       bool allSlots) {
    std::vector<NormalBlock> blocks;
    while (blocks.size() < count) {
        const Vec3 d = randomDirection(rng);
        const auto offsets = slotOffsets(static_cast<unsigned>(rng() % 3));
        NormalBlock b;
        b.mask = 0;
        for (unsigned s = 0; s < 16; ++s) {
            const double x = radius * d[0] + offsets[s][0], y = radius * d[1] + offsets[s][1],
                         z = radius * d[2] + offsets[s][2];
            b.normals[s] = normalised(x, y, z);
            if (allSlots || std::fabs(std::sqrt(x * x + y * y + z * z) - radius) < 0.87)
                b.mask |= 1u << s;
        }
        if (b.mask) blocks.push_back(b);
    }
    return blocks;
}

/// Height field z = A sin(x/λ) cos(0.7 y/λ), randomly rotated; slots the surface crosses.
std::vector<NormalBlock> bumpyPatches(std::mt19937& rng, std::size_t count, double amplitude,
                                      double wavelength) {
    std::uniform_real_distribution<double> unit(0, 1);
    std::vector<NormalBlock> blocks;
    while (blocks.size() < count) {
        // A random rotation: quaternion from four normal deviates.
        std::normal_distribution<double> g;
        double qw = g(rng), qx = g(rng), qy = g(rng), qz = g(rng);
        const double ql = std::sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
        qw /= ql, qx /= ql, qy /= ql, qz /= ql;
        const double rot[3][3]{
            {1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)},
            {2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)},
            {2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)}};
        const double cx = 1000 * unit(rng), cy = 1000 * unit(rng);
        const auto height = [&](double x, double y) {
            return amplitude * std::sin(x / wavelength) * std::cos(0.7 * y / wavelength);
        };
        const double cz = height(cx, cy);
        const auto offsets = slotOffsets(static_cast<unsigned>(rng() % 2));
        NormalBlock b;
        b.mask = 0;
        for (unsigned s = 0; s < 16; ++s) {
            const double x = cx + offsets[s][0], y = cy + offsets[s][1], z = cz + offsets[s][2];
            const double hx =
                amplitude / wavelength * std::cos(x / wavelength) * std::cos(0.7 * y / wavelength);
            const double hy = -0.7 * amplitude / wavelength * std::sin(x / wavelength) *
                              std::sin(0.7 * y / wavelength);
            const double n[3]{-hx, -hy, 1};
            b.normals[s] = normalised(rot[0][0] * n[0] + rot[0][1] * n[1] + rot[0][2] * n[2],
                                      rot[1][0] * n[0] + rot[1][1] * n[1] + rot[1][2] * n[2],
                                      rot[2][0] * n[0] + rot[2][1] * n[1] + rot[2][2] * n[2]);
            if (std::fabs(z - height(x, y)) < 0.87) b.mask |= 1u << s;
        }
        if (b.mask) blocks.push_back(b);
    }
    return blocks;
}

/// 16 directions uniform within @p halfAngle of a random axis, all slots used.
std::vector<NormalBlock> randomCones(std::mt19937& rng, std::size_t count, double halfAngle) {
    std::vector<NormalBlock> blocks(count);
    for (NormalBlock& b : blocks) b.normals = vox::corpus::randomCone(rng, halfAngle);
    return blocks;
}

double angleDegrees(const Vec3& a, const Vec3& b) {
    return vox::corpus::angle(a, b) * 180.0 / std::numbers::pi;
}

nlohmann::json normalSuite(const std::vector<NormalBlock>& blocks) {
    std::vector<std::array<std::uint32_t, 4>> words(blocks.size());
    double best = 1e30;
    for (int r = 0; r < 3; ++r) {
        const double start = threadSeconds();
        for (std::size_t i = 0; i < blocks.size(); ++i)
            words[i] = vox::detail::encodeNormalBlock(blocks[i].normals, blocks[i].mask, g_effort);
        best = std::min(best, threadSeconds() - start);
    }
    std::vector<double> errors, spread;
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        const esvo::CompressedBlock block{0, 0, words[i][0], words[i][1], words[i][2], words[i][3]};
        double widest = 0;
        for (unsigned s = 0; s < 16; ++s) {
            if (!((blocks[i].mask >> s) & 1u)) continue;
            errors.push_back(
                angleDegrees(blocks[i].normals[s], esvo::decodeBlockNormal(block.data(), s)));
            for (unsigned t = 0; t < s; ++t)
                if ((blocks[i].mask >> t) & 1u)
                    widest =
                        std::max(widest, angleDegrees(blocks[i].normals[s], blocks[i].normals[t]));
        }
        spread.push_back(widest);
    }
    double sum = 0;
    for (double e : errors) sum += e;
    std::sort(errors.begin(), errors.end());
    std::sort(spread.begin(), spread.end());
    return {{"blocks", blocks.size()},
            {"normals", errors.size()},
            {"median_block_spread_deg", spread[spread.size() / 2]},
            {"mean_deg", sum / static_cast<double>(errors.size())},
            {"p99_deg", errors[errors.size() * 99 / 100]},
            {"max_deg", errors.back()},
            {"us_per_block", 1e6 * best / static_cast<double>(blocks.size())}};
}

/// A block as the writer hands it to encodeCompressedBlock: the 16 uncompressed values (colour
/// word | normal word << 32) and the used slots (vox::corpus::sceneBlocks forms them from an
/// octree).
using RawBlock = vox::corpus::SceneBlock;

/// The colour and normal halves of raw blocks, as encodeCompressedBlock splits them.
void splitBlocks(const std::vector<RawBlock>& raw, std::vector<ColorBlock>& colors,
                 std::vector<NormalBlock>& normals) {
    for (const RawBlock& r : raw) {
        ColorBlock c;
        NormalBlock n;
        c.mask = n.mask = r.mask;
        for (unsigned s = 0; s < 16; ++s) {
            c.colors[s] = static_cast<std::uint32_t>(r.values[s]) | 0xFF000000u;
            n.normals[s] = esvo::decodeUnitNormal(static_cast<std::uint32_t>(r.values[s] >> 32));
        }
        colors.push_back(c);
        normals.push_back(n);
    }
}

/// Whole-block encoding (encodeCompressedBlock, as the writer calls it) of @p raw.
nlohmann::json compressedSuite(const std::vector<RawBlock>& raw) {
    double best = 1e30;
    std::uint32_t sink = 0;
    for (int r = 0; r < 3; ++r) {
        const double start = threadSeconds();
        for (const RawBlock& b : raw) {
            const esvo::CompressedBlock block =
                vox::detail::encodeCompressedBlock(b.values, b.mask, g_effort);
            for (const std::uint32_t w : block) sink = std::rotl(sink, 5) ^ w;
        }
        best = std::min(best, threadSeconds() - start);
    }
    return {{"blocks", raw.size()},
            {"us_per_block", 1e6 * best / static_cast<double>(raw.size())},
            {"checksum", sink}};
}

constexpr char kDumpMagic[8] = {'V', 'O', 'X', 'B', 'L', 'K', '1', '\0'};

void writeBlocks(const std::string& file, const std::vector<RawBlock>& raw) {
    std::ofstream out(file, std::ios::binary);
    out.write(kDumpMagic, sizeof kDumpMagic);
    const std::uint64_t count = raw.size();
    out.write(reinterpret_cast<const char*>(&count), sizeof count);
    for (const RawBlock& b : raw) {
        out.write(reinterpret_cast<const char*>(b.values.data()), sizeof b.values);
        out.write(reinterpret_cast<const char*>(&b.mask), sizeof b.mask);
    }
    if (!out) throw vox::IoError(file, "cannot write the block dump");
}

std::vector<RawBlock> readBlocks(const std::string& file, std::size_t stride) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw vox::IoError(file, "cannot open the block dump");
    char magic[8]{};
    std::uint64_t count = 0;
    in.read(magic, sizeof magic);
    in.read(reinterpret_cast<char*>(&count), sizeof count);
    if (!in || !std::equal(magic, magic + 8, kDumpMagic))
        throw vox::InvalidDataError(file, "not a block dump");
    std::vector<RawBlock> raw;
    for (std::uint64_t i = 0; i < count; ++i) {
        RawBlock b;
        in.read(reinterpret_cast<char*>(b.values.data()), sizeof b.values);
        in.read(reinterpret_cast<char*>(&b.mask), sizeof b.mask);
        if (!in) throw vox::InvalidDataError(file, "block dump truncated");
        if (i % stride == 0) raw.push_back(b);
    }
    return raw;
}

nlohmann::json blockSuites(const std::vector<RawBlock>& raw) {
    std::vector<ColorBlock> colors;
    std::vector<NormalBlock> normals;
    splitBlocks(raw, colors, normals);
    return {{"color_blocks", colorSuite(colors)},
            {"normal_blocks", normalSuite(normals)},
            {"compressed_blocks", compressedSuite(raw)}};
}

int blocksMode(int argc, char** argv) {
    std::string file;
    std::size_t stride = 1;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string key = argv[i];
        if (key == "--blocks")
            file = argv[i + 1];
        else if (key == "--stride")
            stride = std::max<std::size_t>(1, std::stoul(argv[i + 1]));
    }
    nlohmann::json out = blockSuites(readBlocks(file, stride));
    out["blocks_file"] = file;
    out["effort"] = effortName(g_effort);
    out["kernels"] = vox::attributeEncoderKernels();
    out["stride"] = stride;
    std::cout << out.dump(2) << '\n';
    return 0;
}

int sceneMode(int argc, char** argv) {
    std::string file, dump;
    std::uint32_t depth = 10;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string key = argv[i];
        if (key == "--scene")
            file = argv[i + 1];
        else if (key == "--depth")
            depth = static_cast<std::uint32_t>(std::stoul(argv[i + 1]));
        else if (key == "--dump")
            dump = argv[i + 1];
    }
    vox::log::setVerbosity(vox::log::Verbosity::Quiet);
    const vox::Scene scene = vox::importScene(file);
    vox::SurfaceVoxelizeOptions options;
    options.depth = depth;
    options.attributes = true;
    const vox::SparseOctree octree = vox::voxelizeSurface(scene, options);
    const std::vector<RawBlock> raw = vox::corpus::sceneBlocks(octree);
    if (!dump.empty()) writeBlocks(dump, raw);
    nlohmann::json out;
    out["scene"] = file;
    out["effort"] = effortName(g_effort);
    out["kernels"] = vox::attributeEncoderKernels();
    out["depth"] = depth;
    out["voxels"] = octree.voxelCount();
    // Laine & Karras 5.7, "combined indirect attribute lookup", sized without building it: a
    // 32-bit lookup entry per descriptor (mask + pointer, as the uncompressed attachment has) and
    // the stored values — those that differ from their parent's, as the uncompressed writer
    // omits them — compressed 16 consecutive values to a 24-byte block, against the pair blocks.
    std::uint64_t descriptors = 0, stored = 0;
    {
        std::vector<std::uint64_t> first(octree.leafDepth + 1, 0);
        for (std::uint32_t l = 0; l < octree.leafDepth; ++l) {
            std::uint64_t child = 0;
            for (std::size_t i = 0; i < octree.masks[l].size(); ++i) {
                const unsigned valid = octree.masks[l][i];
                if (valid) ++descriptors;
                for (unsigned slot = 0; slot < 8; ++slot)
                    if (valid & (1u << slot)) {
                        if (l == 0 || octree.attributes[l + 1][child] != octree.attributes[l][i])
                            ++stored;
                        ++child;
                    }
            }
        }
    }
    const double voxels = static_cast<double>(octree.voxelCount());
    out["bytes_per_voxel"] = {
        {"pair_blocks_without_padding", 24.0 * static_cast<double>(raw.size()) / voxels},
        {"combined_lookup_estimate", (4.0 * static_cast<double>(descriptors) +
                                      24.0 * std::ceil(static_cast<double>(stored) / 16.0)) /
                                         voxels},
        {"combined_lookup_lookup_part", 4.0 * static_cast<double>(descriptors) / voxels},
        {"stored_value_fraction", static_cast<double>(stored) / voxels}};
    out.update(blockSuites(raw));
    std::cout << out.dump(2) << '\n';
    return 0;
}

}  // namespace

constexpr const char* kUsage =
    "usage: attribute_encode_bench [--effort fast|default|best] [--kernels sse2|auto] "
    "[TILES_PER_TEXTURE] [NORMAL_BLOCKS]\n"
    "       attribute_encode_bench [...] --scene FILE [--depth N] [--dump FILE]\n"
    "       attribute_encode_bench [...] --blocks FILE [--stride K]\n";

int run(int argc, char** argvIn) {
    // --effort E, anywhere; the rest keep their positions.
    std::vector<char*> args;
    for (int i = 0; i < argc; ++i) {
        if (i + 1 < argc && std::string(argvIn[i]) == "--kernels") {
            const std::string k = argvIn[++i];
            if (k != "sse2" && k != "auto") {
                std::fprintf(stderr, "attribute_encode_bench: --kernels must be sse2 or auto\n");
                return 1;
            }
            if (k == "sse2") vox::detail::setEncoderAvx512(false);
            continue;
        }
        if (i + 1 < argc && std::string(argvIn[i]) == "--effort") {
            const std::string e = argvIn[++i];
            if (e == "fast")
                g_effort = AttributeEffort::Fast;
            else if (e == "best")
                g_effort = AttributeEffort::Best;
            else if (e == "default")
                g_effort = AttributeEffort::Default;
            else {
                std::fprintf(stderr,
                             "attribute_encode_bench: --effort must be fast, default or best\n");
                return 1;
            }
            continue;
        }
        if (std::string(argvIn[i]) == "--help" || std::string(argvIn[i]) == "-h") {
            std::fputs(kUsage, stdout);
            return 0;
        }
        args.push_back(argvIn[i]);
    }
    argc = static_cast<int>(args.size());
    char** argv = args.data();
    if (argc > 1 && (std::string(argv[1]) == "--scene" || std::string(argv[1]) == "--blocks"))
        return std::string(argv[1]) == "--scene" ? sceneMode(argc, argv) : blocksMode(argc, argv);
    const std::size_t perTexture = argc > 1 ? std::stoul(argv[1]) : 4000;
    const std::size_t normalBlocks = argc > 2 ? std::stoul(argv[2]) : 20000;
    std::mt19937 rng(2024);

    std::vector<std::string> textures;
    const std::vector<ColorBlock> tiles = textureTiles(perTexture, textures);
    std::vector<ColorBlock> partial = tiles;
    for (ColorBlock& b : partial) b.mask = randomMask(rng, 8);

    nlohmann::json out;
    out["textures"] = textures;
    out["effort"] = effortName(g_effort);
    out["kernels"] = vox::attributeEncoderKernels();
    if (!tiles.empty()) {
        out["color_tiles_full"] = colorSuite(tiles);
        out["color_tiles_8_of_16"] = colorSuite(partial);
    }
    const std::vector<NormalBlock> sphere24 = spherePatches(rng, normalBlocks, 24, false);
    out["normal_sphere_r24_surface"] = normalSuite(sphere24);
    if (!tiles.empty()) {
        // Whole blocks (encodeCompressedBlock): texture tile colours with the sphere's normals and
        // masks.
        std::vector<std::array<std::uint64_t, 16>> values(sphere24.size());
        for (std::size_t i = 0; i < sphere24.size(); ++i)
            for (unsigned s = 0; s < 16; ++s)
                values[i][s] = tiles[i % tiles.size()].colors[s] |
                               (std::uint64_t{esvo::encodeNormal(sphere24[i].normals[s])} << 32);
        double best = 1e30;
        std::uint32_t sink = 0;
        for (int r = 0; r < 3; ++r) {
            const double start = threadSeconds();
            for (std::size_t i = 0; i < values.size(); ++i)
                sink ^=
                    vox::detail::encodeCompressedBlock(values[i], sphere24[i].mask, g_effort)[0];
            best = std::min(best, threadSeconds() - start);
        }
        out["compressed_block_tiles_and_sphere_r24"] = {
            {"blocks", values.size()},
            {"us_per_block", 1e6 * best / static_cast<double>(values.size())},
            {"checksum", sink}};
    }
    out["normal_sphere_r24_all_slots"] = normalSuite(spherePatches(rng, normalBlocks, 24, true));
    out["normal_sphere_r8_surface"] = normalSuite(spherePatches(rng, normalBlocks, 8, false));
    out["normal_sphere_r128_surface"] = normalSuite(spherePatches(rng, normalBlocks, 128, false));
    out["normal_bumpy_surface"] = normalSuite(bumpyPatches(rng, normalBlocks, 3.0, 6.0));
    out["normal_random_cone_5deg"] =
        normalSuite(randomCones(rng, normalBlocks, 5 * std::numbers::pi / 180));
    out["normal_random_cone_20deg"] =
        normalSuite(randomCones(rng, normalBlocks, 20 * std::numbers::pi / 180));
    std::cout << out.dump(2) << '\n';
    return 0;
}

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const vox::Error& e) {
        std::fprintf(stderr, "attribute_encode_bench: error: %s\n", e.what());
        return static_cast<int>(e.exitCode());
    } catch (
        const std::exception& e) {  // a number that does not parse (std::stoul), a bad allocation
        std::fprintf(stderr, "attribute_encode_bench: error: %s\n%s", e.what(), kUsage);
        return 1;
    }
}

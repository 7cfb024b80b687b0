// Colour and normal attachments end to end: the uncompressed (palette) and compressed (DXT-style)
// encodings written by writeEsvo, checked by the validator, streamed into an EsvoPool and read
// back by the ray caster, against the triangle reference rendering of the same scene.
#include <vox/base/error.h>
#include <vox/formats/esvo_attributes.h>
#include <vox/formats/esvo_reader.h>
#include <vox/import.h>
#include <vox/octree.h>
#include <vox/raycast.h>
#include <vox/triangle_raycast.h>

#include "cornell_box.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

namespace fs = std::filesystem;

namespace {

struct Fixture {
    vox::Scene scene;
    vox::SparseOctree octree;
};

/// The textured example (the Cornell box, its tall box checkered), voxelized with attributes.
const Fixture& cornellBox(std::uint32_t depth) {
    static std::map<std::uint32_t, Fixture> cache;
    auto it = cache.find(depth);
    if (it != cache.end()) return it->second;
    static vox::test::ScratchDir dir;
    Fixture f;
    f.scene = vox::importScene(vox::scenes::writeCornellBox(dir.path()));
    vox::SurfaceVoxelizeOptions options;
    options.depth = depth;
    options.contours = true;
    options.attributes = true;
    f.octree = vox::voxelizeSurface(f.scene, options);
    return cache.emplace(depth, std::move(f)).first->second;
}

fs::path write(const vox::SparseOctree& octree, const fs::path& file,
               vox::AttributeEncoding encoding, std::uint32_t sliceBytes = 1u << 20,
               std::uint32_t nearLimit = 0x7FFF) {
    vox::EsvoWriteOptions options;
    options.attributes = encoding;
    options.sliceBytes = sliceBytes;
    options.nearPointerLimit = nearLimit;
    vox::writeEsvo(file, octree, options);
    return file;
}

vox::PinholeCamera frontView(int size) {
    vox::PinholeCamera camera;
    camera.eye = {0, 1, 3.2};
    camera.target = {0, 1, 0};
    camera.width = camera.height = size;
    return camera;
}

vox::RenderBuffers renderColours(const fs::path& file, const vox::PinholeCamera& camera) {
    const vox::esvo::EsvoReader reader(file);
    vox::esvo::EsvoPool pool(reader);
    pool.loadAll();
    const vox::EsvoRayCaster caster(pool);
    vox::CastOptions options;
    options.attributes = true;
    return vox::renderEsvo(caster, camera, options);
}

/// PSNR (dB) of 8-bit sRGB colours over the pixels both images hit; counts those pixels.
double psnr(const vox::RenderBuffers& a, const vox::RenderBuffers& b,
            std::size_t* compared = nullptr) {
    double squared = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.color.size(); ++i) {
        if (!std::isfinite(a.depth[i]) || !std::isfinite(b.depth[i])) continue;
        for (unsigned ch = 0; ch < 3; ++ch) {
            const double d = double(vox::esvo::colorChannel(a.color[i], ch)) -
                             double(vox::esvo::colorChannel(b.color[i], ch));
            squared += d * d;
        }
        ++n;
    }
    if (compared) *compared = n;
    return squared == 0 ? 99.0 : 10 * std::log10(255.0 * 255.0 * 3.0 * double(n) / squared);
}

}  // namespace

TEST(EsvoAttributes, BothEncodingsValidateAcrossSmallSlicesAndFarPointers) {
    vox::test::ScratchDir dir;
    const vox::SparseOctree& octree = cornellBox(7).octree;
    for (const auto encoding : {vox::AttributeEncoding::Raw, vox::AttributeEncoding::Compressed,
                                vox::AttributeEncoding::CompressedLookup}) {
        const fs::path file = write(octree, dir / "small.esvo", encoding, 16384, 32);
        const vox::esvo::EsvoReader reader(file);
        EXPECT_GT(reader.sliceCount(), 4u);
        const vox::esvo::FileBreakdown b = vox::esvo::validateFile(reader);
        EXPECT_EQ(b.descriptorBytes + b.farPointerBytes + b.pageHeaderBytes + b.infoBytes +
                      b.paddingBytes + b.contourBytes + b.attributeLookupBytes +
                      b.attributeValueBytes + b.attributeBlockBytes + b.headerAndDirectoryBytes +
                      b.slicePaddingBytes,
                  reader.header().fileBytes);
        std::uint64_t descriptors = 0, far = 0;
        for (const auto& s : reader.directory().slices)
            descriptors += s.descriptorCount, far += s.farPointerCount;
        EXPECT_GT(far, 0u);
        if (encoding == vox::AttributeEncoding::Raw) {
            EXPECT_EQ(reader.header().attachmentKinds, 0b011u);
            // A lookup word per unit of every descriptor area; a value for each voxel that differs
            // from its parent — few on the box's flat single-colour walls.
            EXPECT_GE(b.attributeLookupBytes, 4 * descriptors);
            EXPECT_GT(b.attributeValueBytes, 0u);
            EXPECT_LT(b.attributeValueBytes, 8 * octree.voxelCount() / 4);
            EXPECT_EQ(b.attributeBlockBytes, 0u);
        } else if (encoding == vox::AttributeEncoding::CompressedLookup) {
            EXPECT_EQ(reader.header().attachmentKinds, 0b1000001u);
            // A lookup word per unit, then a block per 16 value slots — few on flat walls: less
            // than half of the 12 bytes per descriptor that Dxt's pair blocks take at least.
            EXPECT_GE(b.attributeLookupBytes, 4 * descriptors);
            EXPECT_GT(b.attributeBlockBytes, 0u);
            EXPECT_LT(b.attributeBlockBytes, 6 * descriptors);
            EXPECT_EQ(b.attributeValueBytes, 0u);
        } else {
            EXPECT_EQ(reader.header().attachmentKinds, 0b101u);
            // 24 bytes per pair of units: at least half a block per descriptor.
            EXPECT_GE(b.attributeBlockBytes, 12 * descriptors);
            EXPECT_EQ(b.attributeBlockBytes % 24, 0u);
            EXPECT_EQ(b.attributeLookupBytes + b.attributeValueBytes, 0u);
        }
    }
}

TEST(EsvoAttributes, EveryVoxelReadsBackItsValueThroughLookupAndInheritance) {
    // The raw file resolves to exactly the octree's values, voxel by voxel, across slices (most
    // values on the box's walls are inherited, not stored); the compressed ones to close values.
    vox::test::ScratchDir dir;
    const vox::SparseOctree& octree = cornellBox(7).octree;
    std::map<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t, std::uint32_t>, std::uint64_t>
        expected;
    {
        std::vector<vox::esvo::VoxelPosition> level{vox::esvo::VoxelPosition{}};
        for (std::uint32_t l = 0; l <= octree.leafDepth; ++l) {
            std::vector<vox::esvo::VoxelPosition> next;
            for (std::size_t i = 0; i < level.size(); ++i) {
                expected[{l, level[i].x, level[i].y, level[i].z}] = octree.attributes[l][i];
                if (l < octree.leafDepth)
                    for (std::uint32_t s = 0; s < 8; ++s)
                        if (octree.masks[l][i] & (1u << s)) next.push_back(level[i].child(s));
            }
            level = std::move(next);
        }
    }
    const auto resolve = [&](const fs::path& file) {
        const vox::esvo::EsvoReader reader(file);
        vox::esvo::EsvoPool pool(reader);
        pool.loadAll();
        std::vector<std::pair<vox::esvo::VoxelPosition, vox::esvo::AttributeValue>> out;
        pool.forEachVoxel(
            [&](const vox::esvo::VoxelPosition& p, const vox::esvo::AttributeValue* v) {
                ASSERT_NE(v, nullptr);
                out.emplace_back(p, *v);
            });
        return out;
    };
    const auto raw = resolve(write(octree, dir / "raw.esvo", vox::AttributeEncoding::Raw, 16384));
    ASSERT_EQ(raw.size(), octree.voxelCount() - 1);
    for (const auto& [p, v] : raw) {
        const std::uint64_t value = expected.at({p.level, p.x, p.y, p.z});
        ASSERT_EQ(v.color, static_cast<std::uint32_t>(value)) << "level " << p.level;
        const auto n = vox::esvo::decodeUnitNormal(static_cast<std::uint32_t>(value >> 32));
        ASSERT_EQ(v.normal, n);
    }
    for (const auto encoding :
         {vox::AttributeEncoding::Compressed, vox::AttributeEncoding::CompressedLookup}) {
        const auto compressed = resolve(write(octree, dir / "c.esvo", encoding, 16384));
        ASSERT_EQ(compressed.size(), raw.size());
        double squared = 0, angles = 0;
        for (std::size_t i = 0; i < raw.size(); ++i) {
            ASSERT_EQ(compressed[i].first, raw[i].first);
            for (unsigned ch = 0; ch < 3; ++ch) {
                const double d = double(vox::esvo::colorChannel(raw[i].second.color, ch)) -
                                 double(vox::esvo::colorChannel(compressed[i].second.color, ch));
                squared += d * d;
            }
            const auto& a = raw[i].second.normal;
            const auto& b = compressed[i].second.normal;
            angles +=
                std::acos(std::clamp(
                    double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2], -1.0, 1.0)) *
                180 / 3.14159265358979;
        }
        const double psnrDb = 10 * std::log10(255.0 * 255.0 * 3.0 * double(raw.size()) / squared);
        // Pair blocks hold siblings; the lookup's blocks hold 16 consecutive stored values, which
        // on this scene are the edges' and the checker's — a harder mix (docs/esvo-format.md).
        EXPECT_GT(psnrDb, encoding == vox::AttributeEncoding::Compressed ? 40.0 : 30.0)
            << "encoding " << int(encoding);
        EXPECT_LT(angles / double(raw.size()), 3.0) << "encoding " << int(encoding);
    }
}

TEST(EsvoAttributes, RenderedColoursMatchTheTriangleRendering) {
    // The textured example at depth 9 from the front, 256²: the octree's colours (the raw values,
    // inherited from ancestors where omitted) against the material the triangle caster shades.
    vox::test::ScratchDir dir;
    const Fixture& f = cornellBox(9);
    const vox::PinholeCamera camera = frontView(256);
    const vox::TriangleRayCaster triangles(f.scene);
    const vox::RenderBuffers reference = vox::renderTriangles(triangles, camera);
    const vox::RenderBuffers raw =
        renderColours(write(f.octree, dir / "raw.esvo", vox::AttributeEncoding::Raw), camera);
    const vox::RenderBuffers dxt = renderColours(
        write(f.octree, dir / "dxt.esvo", vox::AttributeEncoding::Compressed), camera);
    std::size_t compared = 0;
    const double rawPsnr = psnr(raw, reference, &compared);
    EXPECT_GT(compared, 40000u);
    // Walls and boxes are single colours: away from edges and the checker's, exactly the
    // material's 8-bit value; a wrong lookup or a broken inheritance gives another wall's colour.
    std::size_t exact = 0;
    for (std::size_t i = 0; i < raw.color.size(); ++i)
        if (std::isfinite(raw.depth[i]) && std::isfinite(reference.depth[i]) &&
            (raw.color[i] & 0xFFFFFFu) == (reference.color[i] & 0xFFFFFFu))
            ++exact;
    EXPECT_GT(double(exact) / double(compared), 0.85);
    EXPECT_GT(rawPsnr, 30.0);
    const double dxtPsnr = psnr(dxt, reference);
    EXPECT_GT(dxtPsnr, 29.0);
    EXPECT_GT(psnr(dxt, raw), 35.0) << "compressed against raw";
    std::printf(
        "colour PSNR against the triangle rendering: raw %.2f dB, compressed %.2f dB; compressed "
        "against raw %.2f dB\n",
        rawPsnr, dxtPsnr, psnr(dxt, raw));
    // Shading normals: the walls' and the floor's, exactly the faces' on flat surfaces.
    std::size_t aligned = 0;
    for (std::size_t i = 0; i < raw.color.size(); ++i)
        if (std::isfinite(raw.depth[i]) && std::isfinite(reference.depth[i]) &&
            dot(raw.shadingNormal[i], reference.shadingNormal[i]) > 0.9999f)
            ++aligned;
    EXPECT_GT(double(aligned) / double(compared), 0.85);
}

TEST(EsvoAttributes, ValidatorRejectsBrokenAttachments) {
    vox::test::ScratchDir dir;
    const vox::SparseOctree& octree = cornellBox(5).octree;
    const vox::esvo::FrontierDescriptor rootParent{1, {}};
    const auto expectRejected = [&](const fs::path& file, auto&& corrupt, const char* what) {
        const vox::esvo::EsvoReader reader(file);
        ASSERT_EQ(reader.sliceCount(), 1u);
        std::vector<std::uint8_t> block = reader.readSlice(0);
        const vox::esvo::BlockTables t = vox::esvo::readBlockTables(block, file, 0);
        ASSERT_TRUE(t.hasAttributes());
        EXPECT_NO_THROW(vox::esvo::validateBlock(file, reader.header(), 0, reader.slice(0), block,
                                                 {&rootParent, 1}));
        corrupt(block.data(), t);
        try {
            (void)vox::esvo::validateBlock(file, reader.header(), 0, reader.slice(0), block,
                                           {&rootParent, 1});
            ADD_FAILURE() << what << ": not detected";
        } catch (const vox::InvalidDataError& e) {
            EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
        }
    };
    const fs::path raw = write(octree, dir / "raw.esvo", vox::AttributeEncoding::Raw);
    const std::uint32_t rootUnit = 1;  // the root descriptor follows page 0's header
    expectRejected(
        raw,
        [&](std::uint8_t* b, const vox::esvo::BlockTables& t) {
            // The first descriptor that stores values and has an empty slot.
            for (std::uint32_t u = 1; u < t.descriptorEndWord / 2; ++u) {
                const std::uint32_t at = 4 * (t.attributeWord + u);
                const std::uint32_t valid = vox::esvo::load<std::uint32_t>(b + 8 * u) >> 8 & 0xFFu;
                if (vox::esvo::load<std::uint32_t>(b + at) == 0 || valid == 0xFFu) continue;
                vox::esvo::store<std::uint32_t>(
                    b + at, vox::esvo::load<std::uint32_t>(b + at) | (~valid & 0xFFu));
                return;
            }
            ADD_FAILURE() << "no descriptor with an empty slot stores values";
        },
        "mask has bits outside the valid mask");
    expectRejected(
        raw,
        [&](std::uint8_t* b, const vox::esvo::BlockTables& t) {
            const std::uint32_t at = 4 * (t.attributeWord + rootUnit);
            vox::esvo::store<std::uint32_t>(b + at,
                                            vox::esvo::load<std::uint32_t>(b + at) + (2u << 8));
        },
        "not stored in descriptor order");
    expectRejected(
        raw,
        [&](std::uint8_t* b, const vox::esvo::BlockTables& t) {
            vox::esvo::store<std::uint32_t>(b + 4 * (t.attributeWord + 0),
                                            0x101u);  // unit 0 is the page header
        },
        "no descriptor");
    const fs::path dxt = write(octree, dir / "dxt.esvo", vox::AttributeEncoding::Compressed);
    expectRejected(
        dxt,
        [&](std::uint8_t* b, const vox::esvo::BlockTables& t) {
            vox::esvo::store<std::uint32_t>(b + 4 * (t.attributeWord + 2),
                                            0x60000000u);  // block 0's base normal: axis 3
        },
        "invalid cube face");
    // An unknown kind is named, with where it is in the file.
    expectRejected(
        dxt,
        [&](std::uint8_t* b, const vox::esvo::BlockTables& t) {
            vox::esvo::store<std::uint32_t>(
                b + 4 * (t.infoWord + vox::esvo::info::kAttachments + 2), 7u);
        },
        "(file offset");
    // The header must declare the kind the blocks hold.
    const vox::esvo::EsvoReader reader(dxt);
    vox::esvo::Header header = reader.header();
    header.attachmentKinds = 0b011u;
    const std::vector<std::uint8_t> block = reader.readSlice(0);
    EXPECT_THROW(
        (void)vox::esvo::validateBlock(dxt, header, 0, reader.slice(0), block, {&rootParent, 1}),
        vox::InvalidDataError);
}

TEST(EsvoAttributes, CorruptedBlocksAreRejectedOrReadSafely) {
    // Random words of a valid block overwritten: validateBlock either rejects the block with an
    // InvalidDataError or, where the change is one the format allows (a colour, an index, a
    // normal's coordinates), accepts it — and then every value reads back without leaving the
    // block (run under ASan to see that).
    vox::test::ScratchDir dir;
    const vox::SparseOctree& octree = cornellBox(5).octree;
    const vox::esvo::FrontierDescriptor rootParent{1, {}};
    std::uint32_t seed = 12345;
    const auto next = [&] { return seed = seed * 1664525u + 1013904223u; };
    for (const auto encoding : {vox::AttributeEncoding::Raw, vox::AttributeEncoding::Compressed,
                                vox::AttributeEncoding::CompressedLookup}) {
        const fs::path file = write(octree, dir / "c.esvo", encoding);
        const vox::esvo::EsvoReader reader(file);
        ASSERT_EQ(reader.sliceCount(), 1u);
        const std::vector<std::uint8_t> original = reader.readSlice(0);
        const vox::esvo::BlockTables t = vox::esvo::readBlockTables(original, file, 0);
        std::size_t accepted = 0, rejected = 0;
        for (int trial = 0; trial < 400; ++trial) {
            std::vector<std::uint8_t> block = original;
            // Mostly inside the colour/normal attachment, sometimes anywhere.
            const std::uint32_t words = static_cast<std::uint32_t>(block.size() / 4);
            const std::uint32_t w =
                trial % 4 == 0 ? next() % words
                               : t.attributeWord + next() % (t.attributeEndWord - t.attributeWord);
            const std::uint32_t value =
                trial % 3 == 0
                    ? next()
                    : vox::esvo::load<std::uint32_t>(block.data() + 4 * w) ^ (1u << (next() % 32));
            vox::esvo::store<std::uint32_t>(block.data() + 4 * w, value);
            try {
                (void)vox::esvo::validateBlock(file, reader.header(), 0, reader.slice(0), block,
                                               {&rootParent, 1});
            } catch (const vox::InvalidDataError&) {
                ++rejected;
                continue;
            }
            ++accepted;
            const auto* words32 = reinterpret_cast<const std::uint32_t*>(block.data());
            const vox::esvo::BlockTables bt = vox::esvo::readBlockTables(block, file, 0);
            for (std::uint32_t u = 1; u < bt.descriptorEndWord / 2; ++u) {
                const vox::esvo::ChildDescriptor d{words32[2 * u], words32[2 * u + 1]};
                if (d.validMask() == 0) continue;
                for (std::uint32_t slot = 0; slot < 8; ++slot) {
                    vox::esvo::AttributeValue v;
                    if ((d.validMask() >> slot) & 1u)
                        (void)vox::esvo::readAttribute(words32, 2 * u, slot, v);
                }
            }
        }
        EXPECT_GT(rejected, 0u) << int(encoding);
        EXPECT_GT(accepted, 0u) << int(encoding);
    }
}

TEST(EsvoAttributes, FilesWithoutAttributesRenderWithoutThem) {
    vox::test::ScratchDir dir;
    const fs::path none =
        write(cornellBox(5).octree, dir / "none.esvo", vox::AttributeEncoding::None);
    const vox::esvo::EsvoReader reader(none);
    EXPECT_EQ(reader.header().attachmentKinds, 1u);
    (void)vox::esvo::validateFile(reader);
    const vox::RenderBuffers image = renderColours(none, frontView(32));
    EXPECT_GT(image.hits, 0u);
    for (std::uint32_t c : image.color) EXPECT_EQ(c, 0u);
}

#include <vox/formats/esvo.h>
#include <vox/formats/esvo_attributes.h>

#include <algorithm>
#include <bit>
#include <cmath>

namespace vox::esvo {
namespace {
/// 2^(e − 13) for an axis exponent e in 0 … 15, built from its bits: std::ldexp was a measurable
/// share of the block encoder's time.
float axisStep(std::uint32_t e) noexcept { return std::bit_cast<float>((e + 127u - 13u) << 23); }
}  // namespace

std::uint32_t encodeNormal(const Vec3& n) noexcept {
    const float ax = std::fabs(n[0]), ay = std::fabs(n[1]), az = std::fabs(n[2]);
    if (!(ax > 0 || ay > 0 || az > 0)) return 2u << 29;  // +z; also catches NaN
    const std::uint32_t axis = ax >= ay && ax >= az ? 0u : (ay >= az ? 1u : 2u);
    const float dominant = n[axis];
    const float scale = 1.0f / std::fabs(dominant);
    const double u = double(n[(axis + 1) % 3]) * scale, v = double(n[(axis + 2) % 3]) * scale;
    const auto iu =
        static_cast<std::int32_t>(std::clamp(std::lround(u * 16384.0), -16384l, 16383l));
    const auto iv = static_cast<std::int32_t>(std::clamp(std::lround(v * 8192.0), -8192l, 8191l));
    return (dominant < 0 ? 1u << 31 : 0u) | (axis << 29) |
           ((static_cast<std::uint32_t>(iu) & 0x7FFFu) << 14) |
           (static_cast<std::uint32_t>(iv) & 0x3FFFu);
}

Vec3 decodeNormal(std::uint32_t encoded) noexcept {
    std::uint32_t axis = (encoded >> 29) & 3u;
    if (axis == 3)
        axis = 2;  // not produced by encodeNormal; decoded as z so every word means something
    const auto iu = static_cast<std::int32_t>(encoded << 3) >> 17;   // bits 14-28, sign-extended
    const auto iv = static_cast<std::int32_t>(encoded << 18) >> 18;  // bits 0-13
    Vec3 n{};
    n[axis] = (encoded >> 31) ? -1.0f : 1.0f;
    n[(axis + 1) % 3] = static_cast<float>(iu) * (1.0f / 16384.0f);
    n[(axis + 2) % 3] = static_cast<float>(iv) * (1.0f / 8192.0f);
    return n;
}

namespace {
Vec3 normalise(Vec3 n) noexcept {
    const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0)) return {0, 0, 1};
    return {n[0] / len, n[1] / len, n[2] / len};
}
}  // namespace

Vec3 decodeUnitNormal(std::uint32_t encoded) noexcept { return normalise(decodeNormal(encoded)); }

std::array<std::uint32_t, 4> colorPalette(std::uint32_t c0, std::uint32_t c1) noexcept {
    const std::uint32_t a = expandRgb565(c0), b = expandRgb565(c1);
    std::uint32_t two = 0, three = 0;
    for (unsigned ch = 0; ch < 3; ++ch) {
        const std::uint32_t x = colorChannel(a, ch), y = colorChannel(b, ch);
        two |= ((2 * x + y + 1) / 3) << (8 * ch);
        three |= ((x + 2 * y + 1) / 3) << (8 * ch);
    }
    return {a, b, two | 0xFF000000u, three | 0xFF000000u};
}

Vec3 decodeAxis(std::uint32_t bits16) noexcept {
    const float scale = axisStep((bits16 >> 12) & 15u);
    const auto component = [&](unsigned shift) {
        return static_cast<float>(static_cast<std::int32_t>(bits16 << (28 - shift)) >> 28) * scale;
    };
    return {component(0), component(4), component(8)};
}

std::uint32_t encodeAxis(const Vec3& axis) noexcept {
    const float highest = std::max({axis[0], axis[1], axis[2], 0.0f});
    const float lowest = std::min({axis[0], axis[1], axis[2], 0.0f});
    std::uint32_t e = 0;
    // Smallest exponent whose range (−8 … 7 steps) holds every component after rounding (to
    // within half a step: 7.5 clamps to 7, −8.5 to −8).
    while (e < 15 && (highest > 7.5f * axisStep(e) || lowest < -8.5f * axisStep(e))) ++e;
    const float step = axisStep(e);
    std::uint32_t bits = e << 12;
    for (unsigned c = 0; c < 3; ++c) {
        const long q = std::clamp(std::lround(axis[c] / step), -8l, 7l);
        bits |= (static_cast<std::uint32_t>(q) & 15u) << (4 * c);
    }
    return bits;
}

std::uint32_t decodeBlockColor(const std::uint32_t* block, unsigned slot) noexcept {
    return colorPalette(block[0] & 0xFFFFu, block[0] >> 16)[blockIndex(block[1], slot)];
}

Vec3 decodeBlockNormal(const std::uint32_t* block, unsigned slot) noexcept {
    const Vec3 base = decodeNormal(block[2]);
    const Vec3 u = decodeAxis(block[4] & 0xFFFFu), v = decodeAxis(block[4] >> 16);
    const float cu = kAxisWeights[blockIndex(block[3], slot)],
                cv = kAxisWeights[blockIndex(block[5], slot)];
    return normalise({base[0] + cu * u[0] + cv * v[0], base[1] + cu * u[1] + cv * v[1],
                      base[2] + cu * u[2] + cv * v[2]});
}

bool readAttribute(const std::uint32_t* words, std::uint32_t descriptorWord, std::uint32_t slot,
                   AttributeValue& out) noexcept {
    // The descriptor's block: page header → info section → attachment directory.
    const std::uint32_t pageWord = descriptorWord & ~(kPageBytes / 4 - 1);
    const auto infoWord = static_cast<std::uint32_t>(static_cast<std::int64_t>(pageWord) +
                                                     static_cast<std::int32_t>(words[pageWord]));
    const std::uint32_t blockWord = infoWord +
                                    static_cast<std::uint32_t>(static_cast<std::int32_t>(
                                        words[infoWord + info::kFirstDescriptor])) -
                                    2;
    const std::uint32_t unit = (descriptorWord - blockWord) / 2;
    const std::uint32_t count = words[infoWord + info::kAttachmentCount];
    // The descriptor area ends where the first attachment begins (a DxtLookup's blocks follow
    // a lookup word per unit of it).
    const auto attachmentWord = [&](std::uint32_t a) {
        return infoWord + static_cast<std::uint32_t>(static_cast<std::int32_t>(
                              words[infoWord + info::kAttachments + 2 * a + 1]));
    };
    for (std::uint32_t a = 0; a < count; ++a) {
        const std::uint32_t kind = words[infoWord + info::kAttachments + 2 * a];
        const std::uint32_t attach = attachmentWord(a);
        if (kind == static_cast<std::uint32_t>(AttachmentKind::Palette)) {
            const PaletteLookup entry{words[attach + unit]};
            if (!((entry.mask() >> slot) & 1u)) return false;
            const std::uint32_t value =
                attach + entry.valuePointer() + 2 * popc8(entry.mask() & ((1u << slot) - 1u));
            out.color = words[value];
            out.normal = decodeUnitNormal(words[value + 1]);
        } else if (kind == static_cast<std::uint32_t>(AttachmentKind::DxtLookup)) {
            const PaletteLookup entry{words[attach + unit]};
            if (!((entry.mask() >> slot) & 1u)) return false;
            const std::uint32_t value =
                entry.valuePointer() + popc8(entry.mask() & ((1u << slot) - 1u));
            const std::uint32_t descriptorUnits = (attachmentWord(0) - blockWord) / 2;
            const std::uint32_t* block = words + attach + lookupArrayWords(descriptorUnits) +
                                         kCompressedBlockWords * (value / 16);
            out.color = decodeBlockColor(block, value % 16);
            out.normal = decodeBlockNormal(block, value % 16);
        } else if (kind == static_cast<std::uint32_t>(AttachmentKind::Dxt)) {
            const std::uint32_t* block = words + attach + kCompressedBlockWords * (unit / 2);
            const unsigned blockSlot = slot | ((unit & 1u) << 3);
            out.color = decodeBlockColor(block, blockSlot);
            out.normal = decodeBlockNormal(block, blockSlot);
        } else {
            continue;
        }
        return true;
    }
    return false;
}

}  // namespace vox::esvo

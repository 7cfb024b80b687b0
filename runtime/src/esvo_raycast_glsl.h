// The ESVO ray casting compute shader (GLSL 4.50), embedded in the library.
//
// A line-by-line port of EsvoRayCaster::cast() (libvox/src/render/esvo_raycast.cpp) and of
// esvo::readAttribute() and its decoders (formats/src/esvo_attributes.cpp). Why it matches the
// CPU bit for bit on IEEE hardware:
// - every float expression is evaluated in the CPU's order, and every variable is `precise`,
//   so no compiler may fuse a·b − c into an FMA (the CPU build does not contract either);
// - the ray is made in double exactly as PinholeCamera::rayThrough makes it and rounded to float
//   where the CPU rounds it; the origin (the same for every pixel) is rounded on the host;
// - the float bit tricks (POP's highest differing bit, the scale's 2^-k) use floatBitsToUint /
//   uintBitsToFloat, std::bit_cast's counterparts.
// Division and sqrt are correctly rounded on llvmpipe (LLVM's fdiv/sqrt); GPUs that approximate
// them may differ in the last bit of a contour's t, rarely in a pixel.
#pragma once

namespace vox::runtime::detail {

inline constexpr const char* kEsvoRaycastShader = R"GLSL(
#version 450 core
layout(local_size_x = 8, local_size_y = 8) in;

// The EsvoPool arena, word for word (EsvoGpuPool).
layout(std430, binding = 0) readonly buffer Pool { uint words[]; };

// One record per pixel, row 0 at the top.
struct PixelOut {
    float t;           // +inf on a miss
    uint iterations;
    uint flags;        // bits 0-7 level, bit 30 has attributes, bit 31 hit
    uint color;        // esvo packColor word
    vec4 faceNormal;   // xyz world normal of the face or contour entered
    vec4 shadingNormal;// xyz unit decoded shading normal
};
layout(std430, binding = 1) writeonly buffer Output { PixelOut pixels[]; };

uniform double uA[12];          // world -> root cube [0,1]^3, row-major 3x4
uniform dvec3 uForward, uRight, uUp;
uniform double uTanHalf, uAspect;
uniform ivec2 uSize;
uniform vec3 uOrigin;           // the eye in [1,2]^3 octree coordinates, rounded to float on the host
uniform float uLodCoef;         // float(lodAngle * unitScale)
uniform uint uMaxLevel;
uniform uint uRootWord;
uniform uint uFlags;            // bit 0 contours, bit 1 attributes

const int kScaleMax = 23;
const uint kPageWords = 2048u;
const uint kInfoFirstDescriptor = 2u, kInfoAttachmentCount = 3u, kInfoAttachments = 4u;
const uint kPalette = 1u, kDxt = 2u, kDxtLookup = 6u;  // esvo::AttachmentKind

uint popc8(uint m) { return uint(bitCount(m & 0xFFu)); }

// ---- attribute decoding (formats/src/esvo_attributes.cpp) ---------------------------------
vec3 normalise(vec3 n) {
    precise float len = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (!(len > 0.0)) return vec3(0.0, 0.0, 1.0);
    precise vec3 r = vec3(n.x / len, n.y / len, n.z / len);
    return r;
}
vec3 decodeNormal(uint encoded) {
    uint axis = (encoded >> 29) & 3u;
    if (axis == 3u) axis = 2u;
    int iu = int(encoded << 3) >> 17;
    int iv = int(encoded << 18) >> 18;
    precise vec3 n = vec3(0.0);
    n[axis] = (encoded >> 31) != 0u ? -1.0 : 1.0;
    n[(axis + 1u) % 3u] = float(iu) * (1.0 / 16384.0);
    n[(axis + 2u) % 3u] = float(iv) * (1.0 / 8192.0);
    return n;
}
uint expandRgb565(uint c) {
    uint r = (c >> 11) & 31u, g = (c >> 5) & 63u, b = c & 31u;
    return ((r << 3) | (r >> 2)) | (((g << 2) | (g >> 4)) << 8) | (((b << 3) | (b >> 2)) << 16) | (255u << 24);
}
uint decodeBlockColor(uint base, uint slot) {
    uint a = expandRgb565(words[base] & 0xFFFFu), b = expandRgb565(words[base] >> 16);
    uint index = (words[base + 1u] >> (2u * slot)) & 3u;
    if (index == 0u) return a;
    if (index == 1u) return b;
    uint outColor = 0xFF000000u;
    for (uint ch = 0u; ch < 3u; ++ch) {
        uint x = (a >> (8u * ch)) & 0xFFu, y = (b >> (8u * ch)) & 0xFFu;
        uint v = index == 2u ? (2u * x + y + 1u) / 3u : (x + 2u * y + 1u) / 3u;
        outColor |= v << (8u * ch);
    }
    return outColor;
}
vec3 decodeAxis(uint bits16) {
    precise float scale = uintBitsToFloat((((bits16 >> 12) & 15u) + 127u - 13u) << 23);
    precise vec3 r = vec3(float(int(bits16 << 28) >> 28) * scale, float(int(bits16 << 24) >> 28) * scale,
                          float(int(bits16 << 20) >> 28) * scale);
    return r;
}
float axisWeight(uint i) {
    // kAxisWeights {-1, -1/3, 1/3, 1}, the thirds rounded to float as C++ rounds 1.0f / 3.0f.
    float third = uintBitsToFloat(0x3EAAAAABu);
    return i == 0u ? -1.0 : (i == 1u ? -third : (i == 2u ? third : 1.0));
}
vec3 decodeBlockNormal(uint base, uint slot) {
    precise vec3 b = decodeNormal(words[base + 2u]);
    precise vec3 u = decodeAxis(words[base + 4u] & 0xFFFFu);
    precise vec3 v = decodeAxis(words[base + 4u] >> 16);
    precise float cu = axisWeight((words[base + 3u] >> (2u * slot)) & 3u);
    precise float cv = axisWeight((words[base + 5u] >> (2u * slot)) & 3u);
    precise vec3 n = vec3(b.x + cu * u.x + cv * v.x, b.y + cu * u.y + cv * v.y, b.z + cu * u.z + cv * v.z);
    return normalise(n);
}
uint attachmentWord(uint infoWord, uint a) { return infoWord + uint(int(words[infoWord + kInfoAttachments + 2u * a + 1u])); }

// esvo::readAttribute: the value child `slot` of the descriptor at `descriptorWord` stores.
bool readAttribute(uint descriptorWord, uint slot, out uint color, out vec3 normal) {
    uint pageWord = descriptorWord & ~(kPageWords - 1u);
    uint infoWord = uint(int(pageWord) + int(words[pageWord]));
    uint blockWord = infoWord + uint(int(words[infoWord + kInfoFirstDescriptor])) - 2u;
    uint unit = (descriptorWord - blockWord) / 2u;
    uint count = words[infoWord + kInfoAttachmentCount];
    for (uint a = 0u; a < count; ++a) {
        uint kind = words[infoWord + kInfoAttachments + 2u * a];
        uint attach = attachmentWord(infoWord, a);
        if (kind == kPalette) {
            uint entry = words[attach + unit];
            if (((entry >> slot) & 1u) == 0u) return false;
            uint value = attach + (entry >> 8) + 2u * popc8(entry & ((1u << slot) - 1u));
            color = words[value];
            normal = normalise(decodeNormal(words[value + 1u]));
        } else if (kind == kDxtLookup) {
            uint entry = words[attach + unit];
            if (((entry >> slot) & 1u) == 0u) return false;
            uint value = (entry >> 8) + popc8(entry & ((1u << slot) - 1u));
            uint descriptorUnits = (attachmentWord(infoWord, 0u) - blockWord) / 2u;
            uint block = attach + descriptorUnits + (descriptorUnits & 1u) + 6u * (value / 16u);
            color = decodeBlockColor(block, value % 16u);
            normal = decodeBlockNormal(block, value % 16u);
        } else if (kind == kDxt) {
            uint block = attach + 6u * (unit / 2u);
            uint blockSlot = slot | ((unit & 1u) << 3);
            color = decodeBlockColor(block, blockSlot);
            normal = decodeBlockNormal(block, blockSlot);
        } else {
            continue;
        }
        return true;
    }
    return false;
}

float copysignEps(float eps, float v) { return (floatBitsToUint(v) & 0x80000000u) != 0u ? -eps : eps; }

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (pixel.x >= uSize.x || pixel.y >= uSize.y) return;
    uint outIndex = uint(pixel.y) * uint(uSize.x) + uint(pixel.x);

    // ---- the ray: PinholeCamera::rayThrough in double ----
    precise double spx = double(pixel.x) + 0.5lf, spy = double(pixel.y) + 0.5lf;
    precise double sx = (spx / double(uSize.x) * 2.0lf - 1.0lf) * uTanHalf * uAspect;
    precise double sy = (1.0lf - spy / double(uSize.y) * 2.0lf) * uTanHalf;
    precise dvec3 v = dvec3(uForward.x + uRight.x * sx + uUp.x * sy, uForward.y + uRight.y * sx + uUp.y * sy,
                            uForward.z + uRight.z * sx + uUp.z * sy);
    precise double vlen = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    precise dvec3 dw = vlen > 0.0lf ? dvec3(v.x / vlen, v.y / vlen, v.z / vlen) : dvec3(0.0lf);

    float epsilon = uintBitsToFloat(uint(127 - kScaleMax) << 23);  // 2^-23
    precise float px = uOrigin.x, py = uOrigin.y, pz = uOrigin.z;
    precise float dx = float(uA[0] * dw.x + uA[1] * dw.y + uA[2] * dw.z);
    precise float dy = float(uA[4] * dw.x + uA[5] * dw.y + uA[6] * dw.z);
    precise float dz = float(uA[8] * dw.x + uA[9] * dw.y + uA[10] * dw.z);
    if (abs(dx) < epsilon) dx = copysignEps(epsilon, dx);
    if (abs(dy) < epsilon) dy = copysignEps(epsilon, dy);
    if (abs(dz) < epsilon) dz = copysignEps(epsilon, dz);

    precise float txCoef = 1.0 / -abs(dx), tyCoef = 1.0 / -abs(dy), tzCoef = 1.0 / -abs(dz);
    precise float txBias = txCoef * px, tyBias = tyCoef * py, tzBias = tzCoef * pz;
    int octantMask = 7;
    if (dx > 0.0) { octantMask ^= 1; txBias = 3.0 * txCoef - txBias; }
    if (dy > 0.0) { octantMask ^= 2; tyBias = 3.0 * tyCoef - tyBias; }
    if (dz > 0.0) { octantMask ^= 4; tzBias = 3.0 * tzCoef - tzBias; }

    precise float tMin = max(max(2.0 * txCoef - txBias, 2.0 * tyCoef - tyBias), 2.0 * tzCoef - tzBias);
    precise float tMax = min(min(txCoef - txBias, tyCoef - tyBias), tzCoef - tzBias);
    tMin = max(tMin, 0.0);
    tMax = min(tMax, 3.0e38);

    PixelOut result;
    result.t = uintBitsToFloat(0x7F800000u);
    result.iterations = 0u;
    result.flags = 0u;
    result.color = 0u;
    result.faceNormal = vec4(0.0);
    result.shadingNormal = vec4(0.0);
    if (!(tMin <= tMax)) { pixels[outIndex] = result; return; }

    uint stackParent[kScaleMax + 1];
    float stackTMax[kScaleMax + 1];
    bool contours = (uFlags & 1u) != 0u;

    uint parent = uRootWord;
    uint descriptor = 0u, descriptor2 = 0u;
    bool haveDescriptor = false;
    precise float slabT = -1.0;
    precise vec3 slabNormal = vec3(0.0);
    int idx = 0;
    precise float posX = 1.0, posY = 1.0, posZ = 1.0;
    int scale = kScaleMax - 1;
    precise float scaleExp2 = 0.5;
    if (1.5 * txCoef - txBias > tMin) { idx ^= 1; posX = 1.5; }
    if (1.5 * tyCoef - tyBias > tMin) { idx ^= 2; posY = 1.5; }
    if (1.5 * tzCoef - tzBias > tMin) { idx ^= 4; posZ = 1.5; }

    bool hit = false;
    int hitSlot = 0;
    uint level = 0u;
    uint iterations = 0u;
    while (scale < kScaleMax) {
        ++iterations;
        if (!haveDescriptor) {
            descriptor = words[parent];
            descriptor2 = words[parent + 1u];
            haveDescriptor = true;
        }
        precise float txCorner = posX * txCoef - txBias;
        precise float tyCorner = posY * tyCoef - tyBias;
        precise float tzCorner = posZ * tzCoef - tzBias;
        precise float tcMax = min(min(txCorner, tyCorner), tzCorner);

        int slot = idx ^ octantMask ^ 7;
        bool valid = ((descriptor >> (8 + slot)) & 1u) != 0u;
        if (valid && tMin <= tMax) {
            uint voxelLevel = uint(kScaleMax - scale);
            if (uLodCoef > 0.0 && tcMax * uLodCoef >= scaleExp2) {
                hit = true; level = voxelLevel; hitSlot = slot;
                break;
            }
            precise float tvMax = min(tMax, tcMax);
            precise float half_ = scaleExp2 * 0.5;
            precise float txCenter = (posX + half_) * txCoef - txBias;
            precise float tyCenter = (posY + half_) * tyCoef - tyBias;
            precise float tzCenter = (posZ + half_) * tzCoef - tzBias;
            precise float tvMin = tMin;
            bool fromSlab = false;
            precise vec3 slabN = vec3(0.0);
            if (contours && ((descriptor2 >> slot) & 1u) != 0u) {
                uint pointer = descriptor2 >> 8;
                uint c = words[parent + pointer + popc8(descriptor2 & ((1u << slot) - 1u))];
                int cnx = bitfieldExtract(int(c), 12, 6), cny = bitfieldExtract(int(c), 6, 6), cnz = bitfieldExtract(int(c), 0, 6);
                int cpos = bitfieldExtract(int(c), 18, 7);
                uint cth = c >> 25;
                precise float cx = (octantMask & 1) != 0 ? posX + half_ : 3.0 - posX - half_;
                precise float cy = (octantMask & 2) != 0 ? posY + half_ : 3.0 - posY - half_;
                precise float cz = (octantMask & 4) != 0 ? posZ + half_ : 3.0 - posZ - half_;
                precise float nd = float(cnx) * dx + float(cny) * dy + float(cnz) * dz;
                precise float no = float(cnx) * (px - cx) + float(cny) * (py - cy) + float(cnz) * (pz - cz);
                precise float centreOffset = scaleExp2 * float(cpos) * 0.75;
                precise float halfThickness = scaleExp2 * float(cth) * 0.75 * 0.5;
                precise float lo = centreOffset - halfThickness - no, hi = centreOffset + halfThickness - no;
                if (nd != 0.0) {
                    precise float t0 = lo / nd, t1 = hi / nd;
                    if (nd < 0.0) { precise float s = t0; t0 = t1; t1 = s; }
                    if (t0 > tvMin) {
                        tvMin = t0;
                        fromSlab = true;
                        float sgn = nd > 0.0 ? -1.0 : 1.0;
                        slabN = vec3(sgn * float(cnx), sgn * float(cny), sgn * float(cnz));
                    }
                    tvMax = min(tvMax, t1);
                } else if (lo > 0.0 || hi < 0.0) {
                    tvMax = -1.0;
                }
            }
            if (tvMin <= tvMax) {
                bool leaf = ((descriptor >> slot) & 1u) == 0u || voxelLevel >= uMaxLevel;
                int offset = int(descriptor >> 17);
                if (!leaf && (descriptor & 0x10000u) != 0u) {
                    offset = int(words[parent + 2u * uint(offset)]);
                    leaf = offset == 0;  // child slice not loaded
                }
                if (fromSlab) { slabT = tvMin; slabNormal = slabN; }
                if (leaf) {
                    hit = true; level = voxelLevel; hitSlot = slot;
                    tMin = tvMin;
                    break;
                }
                // PUSH (always stored, as the CPU caster does)
                stackParent[scale] = parent;
                stackTMax[scale] = tMax;
                offset += int(popc8(descriptor & ((1u << slot) - 1u)));
                parent = uint(int(parent) + 2 * offset);
                idx = 0;
                --scale;
                scaleExp2 = half_;
                tMin = tvMin;
                tMax = tvMax;
                if (txCenter > tMin) { idx ^= 1; posX += scaleExp2; }
                if (tyCenter > tMin) { idx ^= 2; posY += scaleExp2; }
                if (tzCenter > tMin) { idx ^= 4; posZ += scaleExp2; }
                haveDescriptor = false;
                continue;
            }
        }

        // ADVANCE
        int stepMask = 0;
        if (txCorner <= tcMax) { stepMask ^= 1; posX -= scaleExp2; }
        if (tyCorner <= tcMax) { stepMask ^= 2; posY -= scaleExp2; }
        if (tzCorner <= tcMax) { stepMask ^= 4; posZ -= scaleExp2; }
        tMin = tcMax;
        idx ^= stepMask;
        if ((idx & stepMask) != 0) {
            // POP: the highest differing bit of the positions gives the scale.
            uint differing = 0u;
            if ((stepMask & 1) != 0) differing |= floatBitsToUint(posX) ^ floatBitsToUint(posX + scaleExp2);
            if ((stepMask & 2) != 0) differing |= floatBitsToUint(posY) ^ floatBitsToUint(posY + scaleExp2);
            if ((stepMask & 4) != 0) differing |= floatBitsToUint(posZ) ^ floatBitsToUint(posZ + scaleExp2);
            scale = int(floatBitsToUint(float(differing)) >> 23) - 127;
            if (scale >= kScaleMax) break;
            scaleExp2 = uintBitsToFloat(uint(scale - kScaleMax + 127) << 23);
            parent = stackParent[scale];
            tMax = stackTMax[scale];
            uint shx = floatBitsToUint(posX) >> scale;
            uint shy = floatBitsToUint(posY) >> scale;
            uint shz = floatBitsToUint(posZ) >> scale;
            posX = uintBitsToFloat(shx << scale);
            posY = uintBitsToFloat(shy << scale);
            posZ = uintBitsToFloat(shz << scale);
            idx = int((shx & 1u) | ((shy & 1u) << 1) | ((shz & 1u) << 2));
            haveDescriptor = false;
        }
    }
    result.iterations = iterations;
    if (!hit) { pixels[outIndex] = result; return; }

    result.t = tMin;
    result.flags = 0x80000000u | level;
    precise float txEntry = (posX + scaleExp2) * txCoef - txBias;
    precise float tyEntry = (posY + scaleExp2) * tyCoef - tyBias;
    precise float tzEntry = (posZ + scaleExp2) * tzCoef - tzBias;
    precise dvec3 n = dvec3(0.0lf);
    if (slabT == tMin && slabT >= max(max(txEntry, tyEntry), tzEntry))
        n = dvec3(slabNormal);
    else if (txEntry >= tyEntry && txEntry >= tzEntry)
        n.x = dx > 0.0 ? -1.0lf : 1.0lf;
    else if (tyEntry >= tzEntry)
        n.y = dy > 0.0 ? -1.0lf : 1.0lf;
    else
        n.z = dz > 0.0 ? -1.0lf : 1.0lf;
    precise dvec3 nw = dvec3(uA[0] * n.x + uA[4] * n.y + uA[8] * n.z, uA[1] * n.x + uA[5] * n.y + uA[9] * n.z,
                             uA[2] * n.x + uA[6] * n.y + uA[10] * n.z);
    precise double nlen = sqrt(nw.x * nw.x + nw.y * nw.y + nw.z * nw.z);
    precise dvec3 nn = nlen > 0.0lf ? dvec3(nw.x / nlen, nw.y / nlen, nw.z / nlen) : dvec3(0.0lf);
    result.faceNormal = vec4(vec3(nn), 0.0);

    if ((uFlags & 2u) != 0u) {
        uint descriptorWord = parent;
        int slot = hitSlot;
        for (int s = scale;;) {
            uint color;
            vec3 normal;
            if (readAttribute(descriptorWord, uint(slot), color, normal)) {
                result.flags |= 0x40000000u;
                result.color = color;
                result.shadingNormal = vec4(normal, 0.0);
                break;
            }
            if (++s >= kScaleMax) break;
            descriptorWord = stackParent[s];
            int idxAbove = int(((floatBitsToUint(posX) >> s) & 1u) | (((floatBitsToUint(posY) >> s) & 1u) << 1) |
                               (((floatBitsToUint(posZ) >> s) & 1u) << 2));
            slot = idxAbove ^ octantMask ^ 7;
        }
    }
    pixels[outIndex] = result;
}
)GLSL";

}  // namespace vox::runtime::detail

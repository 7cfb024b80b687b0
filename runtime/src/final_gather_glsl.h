// The cone-traced final gather compute shader (GLSL 4.50), embedded in the library.
//
// A port of vox::RadianceField::sample / sampleLod / traceCone / gatherDiffuse
// (libvox/src/radiance/radiance_field.cpp), rvol::combineDirectional (formats/src/rvol.cpp),
// vox::lightArrival (libvox/src/lighting/punctual.cpp) and FinalGather::visibility / shade
// (libvox/src/radiance/final_gather.cpp), over the atlases of RvolGpuVolume: a single .rvol, or a
// tiled volume (rvol::TiledRvolReader's sampling: levels up to the tile depth from the tile owning
// each cell, the levels above from the far field). Differences from the CPU, all below the tests'
// tolerance (docs/runtime.md):
// - float instead of double;
// - the opacity correction 1 − (1 − a)^(step/diameter) with step/diameter = ½ exactly (as on the
//   CPU, where step = 0.5·diameter) written as a / (1 + sqrt(1 − a)): the same value without the
//   cancellation of 1 − sqrt(1 − a) in float;
// - with VOX_HARDWARE_FILTER the radiance (and the A8 opacity) is filtered by the texture unit,
//   whose weights may be fixed point (8 bits on many GPUs); without it, eight texelFetch per
//   plane with float weights, as the CPU does. Binary level-0 opacity is always fetched
//   (GL_R32UI view, corners with a non-zero word), and so is the half cell along a tile border,
//   whose corners lie in different tiles' bricks.
// The host prepends "#version 450 core" and the #defines (VOX_MODE_SHADE or VOX_MODE_SAMPLE,
// VOX_HARDWARE_FILTER, VOX_TILED: compiled for tiled volumes, see FinalGatherGpuOptions).
#pragma once

namespace vox::runtime::detail {

inline constexpr const char* kFinalGatherShader = R"GLSL(
layout(local_size_x = 64) in;

// ---- the volume (RvolGpuVolume::bind) ----
layout(binding = 0) uniform sampler3D uRgbAtlas;    // GL_RGB9_E5, GL_LINEAR
layout(binding = 1) uniform usampler3D uWordAtlas;  // the same storage as GL_R32UI
layout(binding = 2) uniform sampler3D uAlphaAtlas;  // GL_R8, GL_LINEAR

const uint kMissingBrick = 0x80000000u;  // indirection: a brick the GPU does not hold
const uint kMissingTile = 0x80000000u;   // tile table: a tile the GPU does not hold
const uint kAbsentTile = 0x40000000u;    // tile table: a tile the index does not list (all zero)
const uint kNoLevel = 0xFFFFFFFFu;
const uint kBinaryOpacity = 0x10000u;    // LevelInfo.planes: level-0 opacity in the RGB words

// One level table entry. Entries 0 … levelCount − 1 are the volume's levels 0 … depth; a tiled
// volume appends the far field's levels that the tiles also cover (where a tile is missing).
struct LevelInfo {
    uint base;           // first indirection entry; of tiled levels, within a tile's block
    uint bricksPerAxis;  // K of the file the level comes from (a tile's, for tiled levels)
    uint resolution;     // cells per axis over the whole root cube
    uint planes;         // per brick: 2 (isotropic, level-0 layout) or 9; | kBinaryOpacity
    uint tileCells;      // cells per axis of a tile; 0: untiled (a single volume, the far field)
    uint fallback;       // the entry to sample where a brick of this one is missing, or kNoLevel
    uint coarser;        // the next coarser level's entry (sampleLod blends towards it), or kNoLevel
    uint level;          // the volume level of its cells
};
layout(std430, binding = 4) readonly buffer RvolInfo {
    vec4 volOriginSize;   // origin xyz, size
    uvec4 volGeometry;    // depth, N, levelCount (depth + 1), tiles per axis (tiled volumes)
    uvec4 tileBlocks;     // first entry of tile slot 0's block, entries per block
    vec4 rgbAtlasSize;
    vec4 alphaAtlasSize;
    LevelInfo levels[];
};
layout(std430, binding = 5) readonly buffer RvolIndirection { uint slots[]; };
// Per tile (x fastest): its slot, kMissingTile or kAbsentTile. One unused entry for a single volume.
layout(std430, binding = 3) readonly buffer RvolTiles { uint tiles[]; };

uvec3 slotTexel(uint slotWord) {
    return uvec3(slotWord & 1023u, (slotWord >> 10) & 1023u, (slotWord >> 20) & 1023u) * volGeometry.y;
}

// The eight texels trilinear filtering reads around a point at one level, and where they lie
// (set by locate(), read by the filters; globals, so that no call copies the arrays). Bricks share
// faces, so inside one file the eight always lie in one brick (gOneBrick): the hardware filter
// reads them at gT. Across a tile border they lie in two to eight bricks of different tiles,
// fetched one by one (gEntry, gTexel per corner).
bool gOneBrick;
vec3 gT;           // gOneBrick: the continuous texel coordinate in [0, N − 1]
vec3 gF;           // the weights of the upper corners
uint gEntry0;      // gOneBrick: the brick's first indirection entry
ivec3 gTexel0;     // gOneBrick: the lower corner's texel in it
uint gEntry[8];    // else, per corner: its brick's first indirection entry
ivec3 gTexel[8];   // else, per corner: its texel in that brick

float cornerWeight(int c) {
    return ((c & 1) != 0 ? gF.x : 1.0 - gF.x) * ((c & 2) != 0 ? gF.y : 1.0 - gF.y) * ((c & 4) != 0 ? gF.z : 1.0 - gF.z);
}

// The atlas texel of corner c of the footprint in the plane's atlas.
ivec3 cornerTexel(int c, uint plane) {
    if (gOneBrick) return ivec3(slotTexel(slots[gEntry0 + plane])) + gTexel0 + ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    return ivec3(slotTexel(slots[gEntry[c] + plane])) + gTexel[c];
}

// The first indirection entry of brick b of a level whose bricks start at base.
uint brickEntry(LevelInfo L, uint base, uvec3 b) {
    uint k = L.bricksPerAxis;
    return base + ((b.z * k + b.y) * k + b.x) * (L.planes & 0xFFFFu);
}

// Where tile `tile`'s level-L bricks start; false where the tile is not resident. An absent tile
// is all zero: its bricks are entry 0, the zero brick (absent is set).
bool tileLevelBase(LevelInfo L, uvec3 tile, out uint base, out bool absent) {
    uint n = volGeometry.w;
    uint word = tiles[(tile.z * n + tile.y) * n + tile.x];
    absent = word == kAbsentTile;
    base = absent ? 0u : tileBlocks.x + word * tileBlocks.y + L.base;
    return word != kMissingTile;
}

// Where level entry e's filter reads around p (RvolReader::sample's convention over the whole
// level; TiledRvolReader::sample's at tile borders); false where a brick it needs is missing.
bool locate(uint e, vec3 p) {
    LevelInfo L = levels[e];
    float cell = volOriginSize.w / float(L.resolution);
    vec3 u = clamp((p - volOriginSize.xyz) / cell - 0.5, vec3(0.0), vec3(float(L.resolution - 1u)));
    float span = float(volGeometry.y - 1u);
    uvec3 c0 = uvec3(floor(u));
    uvec3 c1 = min(c0 + 1u, uvec3(L.resolution - 1u));
    gOneBrick = L.tileCells == 0u || all(equal(c0 / L.tileCells, c1 / L.tileCells));
    if (gOneBrick) {
        uint base = L.base;
        bool absent = false;
        if (L.tileCells != 0u) {
            uvec3 tile = c0 / L.tileCells;
            if (!tileLevelBase(L, tile, base, absent)) return false;
            u -= vec3(tile * L.tileCells);
        }
        uvec3 b = min(uvec3(floor(u / span)), uvec3(L.bricksPerAxis - 1u));
        gT = u - vec3(b) * span;
        gEntry0 = absent ? 0u : brickEntry(L, base, b);
        vec3 i = min(floor(gT), vec3(span - 1.0));
        gF = gT - i;
        gTexel0 = ivec3(i);
        return slots[gEntry0] != kMissingBrick;
    }
    // Across a tile border: each corner from the tile that owns its cell.
    gF = u - vec3(c0);
    uint n = uint(span);
    for (int c = 0; c < 8; ++c) {
        uvec3 cell = mix(c0, c1, bvec3((c & 1) != 0, (c & 2) != 0, (c & 4) != 0));
        uvec3 tile = cell / L.tileCells;
        uint base;
        bool absent;
        if (!tileLevelBase(L, tile, base, absent)) return false;
        uvec3 local = cell - tile * L.tileCells;
        uvec3 b = min(local / n, uvec3(L.bricksPerAxis - 1u));
        gEntry[c] = absent ? 0u : brickEntry(L, base, b);
        gTexel[c] = ivec3(local - b * n);
        if (slots[gEntry[c]] == kMissingBrick) return false;
    }
    return true;
}

// One RGB plane's radiance.
vec3 filterRgb(uint plane) {
#ifdef VOX_HARDWARE_FILTER
#ifdef VOX_TILED
    if (gOneBrick)
#endif
        return textureLod(uRgbAtlas, (vec3(slotTexel(slots[gEntry0 + plane])) + gT + 0.5) / rgbAtlasSize.xyz, 0.0).rgb;
#endif
    vec3 sum = vec3(0.0);
    for (int c = 0; c < 8; ++c) {
        float w = cornerWeight(c);
        if (w <= 0.0) continue;
        sum += w * texelFetch(uRgbAtlas, cornerTexel(c, plane), 0).rgb;
    }
    return sum;
}

// One A8 plane's opacity, and its transmittance 1 − opacity, computed so that it is 0 where
// the CPU's opacity (a double sum rounded to float) is exactly 1: combineDirectional's
// log(max(1 − a, 1e-12)) jumps from about −16.6 (1 − a = 2^-24) to −27.6 (a = 1) there, so
// every corner's weight must leave no float error below 1.
vec2 filterAlpha(uint plane) {
#ifdef VOX_HARDWARE_FILTER
#ifdef VOX_TILED
    if (gOneBrick)
#endif
    {
        float a = textureLod(uAlphaAtlas, (vec3(slotTexel(slots[gEntry0 + plane])) + gT + 0.5) / alphaAtlasSize.xyz, 0.0).r;
        // The filter's result within two float steps of 1 is an opaque neighbourhood (a sum of
        // weights that does not quite reach 1): fully opaque, as the CPU's float rounding makes it.
        float transmittance = 1.0 - a;
        return transmittance <= exp2(-23.0) ? vec2(1.0, 0.0) : vec2(a, transmittance);
    }
#endif
    float sum = 0.0, transmittance = 0.0;
    for (int c = 0; c < 8; ++c) {
        float w = cornerWeight(c);
        if (w <= 0.0) continue;
        float a = texelFetch(uAlphaAtlas, cornerTexel(c, plane), 0).r;
        sum += w * a;
        transmittance += w * (1.0 - a);
    }
    // Below half a float step under 1 the CPU's opacity rounds to 1.
    return transmittance < exp2(-25.0) ? vec2(1.0, 0.0) : vec2(sum, transmittance);
}

// Binary level-0 opacity: the trilinear weights of the corners whose RGB9E5 word is not 0.
float filterBinaryAlpha() {
    float sum = 0.0;
    for (int c = 0; c < 8; ++c) {
        float w = cornerWeight(c);
        if (w <= 0.0) continue;
        if (texelFetch(uWordAtlas, cornerTexel(c, 0u), 0).r != 0u) sum += w;
    }
    return sum;
}

// rvol::combineDirectional.
// transmittance[a]: 1 − clamp(facing[a].a, 0, 1), computed without cancellation (filterAlpha).
vec4 combineDirectional(vec4 facing[3], float transmittance[3], vec3 d) {
    float length2 = dot(d, d);
    float sumAbs = abs(d.x) + abs(d.y) + abs(d.z);
    if (!(length2 > 0.0)) return vec4(0.0);
    vec3 rgb = vec3(0.0);
    float alphaBlend = 0.0, logTransmittance = 0.0;
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) continue;
        float w = d[a] * d[a] / length2;
        rgb += w * facing[a].rgb;
        alphaBlend += w * facing[a].a;
        logTransmittance += abs(d[a]) / sumAbs * log(max(clamp(transmittance[a], 0.0, 1.0), 1e-12));
    }
    float alpha = 1.0 - exp(logTransmittance);
    float scale = alphaBlend > 1e-12 ? alpha / alphaBlend : 0.0;
    return vec4(rgb * scale, alpha);
}

// RadianceField::sample at level entry e, where locate() found the footprint.
vec4 sampleLevel(uint e, vec3 dir) {
    uint planes = levels[e].planes;
    if ((planes & 0xFFFFu) == 2u) {
        vec3 rgb = filterRgb(0u);
        float a = (planes & kBinaryOpacity) != 0u ? filterBinaryAlpha() : filterAlpha(1u).x;
        return vec4(rgb, a);
    }
    vec4 facing[3];
    float transmittance[3];
    for (int a = 0; a < 3; ++a) {
        uint channel = uint(2 * a) + (dir[a] < 0.0 ? 1u : 0u);
        vec2 alpha = filterAlpha(6u + uint(a));
        facing[a] = vec4(filterRgb(channel), alpha.x);
        transmittance[a] = alpha.y;
    }
    return combineDirectional(facing, transmittance, dir);
}

// What this invocation's samples met: a missing brick served by a coarser cover (gFellBack), or
// one with no resident cover at all, read as zero (gHole).
bool gFellBack = false, gHole = false;

// RadianceField::sampleLod. Where streaming left a brick at the level missing, the entry's
// fallback (the next coarser level; over a tiled level, the far field at the same level or its
// finest) and so on up; a residency keeps those covers whenever it keeps the finer brick.
vec4 sampleLod(float level, vec3 p, vec3 dir) {
    float top = float(volGeometry.z - 1u);
    level = clamp(level, 0.0, top);
    uint e = uint(floor(level));
    while (!locate(e, p)) {
        gFellBack = true;
        e = levels[e].fallback;
        if (e == kNoLevel) {
            gHole = true;
            return vec4(0.0);
        }
    }
    float f = level - float(levels[e].level);  // ≤ 0 where it fell back past the level asked for
    uint c = levels[e].coarser;
    // The level, then the coarser one it blends towards, through one sampleLevel call: a loop of
    // unknown trip count, so that the compiler does not unroll it (every inlined copy of the
    // filters costs a JIT compiler such as llvmpipe's seconds).
    vec4 a = vec4(0.0);
    for (bool first = true;; first = false) {
        vec4 s = sampleLevel(e, dir);
        if (!first) return a + (s - a) * f;
        a = s;
        if (f <= 0.0 || c == kNoLevel || !locate(c, p)) return a;
        e = c;
    }
}

float finestCell() { return volOriginSize.w / float(levels[0].resolution); }

// Per dispatch: the points (queries) whose samples fell back to a coarser cover, or met a hole.
layout(std430, binding = 9) buffer RvolCounters { uint fallbackCount; uint holeCount; };
void countFallbacks() {
    if (gFellBack) atomicAdd(fallbackCount, 1u);
    if (gHole) atomicAdd(holeCount, 1u);
}

struct ConeResult { vec3 radiance; float opacity; float occlusion; };

// RadianceField::traceCone; planeNormal zero: no plane.
ConeResult traceCone(vec3 origin, vec3 dir, float tanHalf, float start, float maxDistance, vec3 planePoint, vec3 planeNormal,
                     float aoLambda, bool opacityOnly) {
    float size = volOriginSize.w;
    vec3 lo = volOriginSize.xyz;
    vec3 hi = lo + vec3(size);
    float top = float(volGeometry.z - 1u);
    float finest = finestCell();
    float t = max(start, 0.5 * finest);
    float opacity = 0.0, occlusion = 0.0;
    vec3 radiance = vec3(0.0);
    bool clampToPlane = planeNormal != vec3(0.0);
    while (t < maxDistance && opacity < 0.995) {
        vec3 p = origin + dir * t;
        float diameter = max(2.0 * t * tanHalf, finest);
        float margin = 0.5 * diameter;
        if (any(lessThan(p, lo - margin)) || any(greaterThan(p, hi + margin))) break;
        float footprint = diameter;
        // Measured where the sample reads (the clamped edge cells beyond the cube).
        if (clampToPlane) footprint = max(finest, min(footprint, dot(clamp(p, lo, hi) - planePoint, planeNormal) / 1.5));
        float level = log2(footprint / finest);
        if (level > top) break;
        float stepLength = 0.5 * diameter;
        vec4 s = sampleLod(level, p, dir);
        if (s.a > 1e-6) {
            float a = clamp(s.a, 0.0, 1.0);
            // 1 − (1 − a)^(step/diameter), step/diameter = 1/2: a / (1 + sqrt(1 − a)).
            float am = min(a, 0.999999);
            float corrected = am / (1.0 + sqrt(1.0 - am));
            if (!opacityOnly) radiance += s.rgb * ((1.0 - opacity) * corrected / a);
            occlusion += (1.0 - occlusion) * corrected / (1.0 + aoLambda * 0.5 * diameter / size);
            opacity += (1.0 - opacity) * corrected;
        }
        t += stepLength;
    }
    return ConeResult(radiance, opacity, occlusion);
}

#ifdef VOX_MODE_SHADE
// ---- the final gather ----
struct GatherPoint { vec4 position; vec4 normal; vec4 albedo; vec4 emission; vec4 view; };
struct GatherParts { vec4 finalColor; vec4 direct; vec4 indirect; vec4 specularAo; };  // specularAo.w: ao
struct GpuLight {
    vec4 positionType;       // xyz position, w type (0 directional, 1 point, 2 spot)
    vec4 directionRange;     // xyz unit direction light travels, w range (0: none)
    vec4 color;              // rgb colour × intensity
    vec4 spot;               // x cos outer, y 1 / max(1e-3, cos inner − cos outer)
};
layout(std430, binding = 6) readonly buffer Points { GatherPoint points[]; };
layout(std430, binding = 7) writeonly buffer Parts { GatherParts parts[]; };
layout(std430, binding = 8) readonly buffer Lights { GpuLight lights[]; };
// The light grid (runtime/src/light_grid.h): per cell its first entry in lightList and count.
layout(std430, binding = 10) readonly buffer LightCells { uvec2 lightCells[]; };
layout(std430, binding = 11) readonly buffer LightList { uint lightList[]; };

uniform uint uCount;
uniform vec3 uLightGridOrigin;
uniform vec3 uLightGridInverseCell;
uniform uvec3 uLightGridCells;
uniform float uOffset;           // offsetCells × finest cell, world
uniform float uAoLambda;
uniform float uSpecularF0;
uniform float uTanHalfSpecular;
uniform float uTanHalfShadow;
uniform bool uShadowCones;
uniform float uDiffuseTanHalf;   // tan 28°
uniform float uDiffuseWeights[2];   // centre, ring (normalised: the seven sum to π)
uniform vec2 uDiffuseTilt;          // cos, sin of the ring's 55° tilt
uniform float uDiffuseCos[6], uDiffuseSin[6];

const float kPi = 3.14159265358979323846;

// vox::lightArrival; false where the light cannot reach p. infinite: directional.
bool lightArrival(GpuLight light, vec3 p, out vec3 toLight, out float distance, out bool infinite, out vec3 irradiance) {
    vec3 color = light.color.rgb;
    uint type = uint(light.positionType.w);
    infinite = false;
    distance = 0.0;
    if (type == 0u) {
        toLight = -normalize(light.directionRange.xyz);
        infinite = true;
        irradiance = color;
        return true;
    }
    vec3 offset = light.positionType.xyz - p;
    float d2 = dot(offset, offset);
    toLight = vec3(0.0, 0.0, 1.0);
    irradiance = vec3(0.0);
    if (!(d2 > 0.0)) return false;
    float d = sqrt(d2);
    toLight = offset / d;
    distance = d;
    float falloff = 1.0 / d2;
    float range = light.directionRange.w;
    if (range > 0.0) {
        if (d >= range) return false;
        float r = d / range;
        float window = clamp(1.0 - r * r * r * r, 0.0, 1.0);
        falloff *= window * window;
    }
    if (type == 2u) {
        vec3 axis = normalize(light.directionRange.xyz);
        float cosAngle = -dot(axis, toLight);
        float t = clamp((cosAngle - light.spot.x) * light.spot.y, 0.0, 1.0);
        if (t <= 0.0) return false;
        falloff *= t * t;
    }
    if (!(falloff > 0.0)) return false;
    irradiance = color * falloff;
    return true;
}

void main() {
    uint index = gl_GlobalInvocationID.x;
    if (index >= uCount) return;
    GatherPoint point = points[index];
    vec3 position = point.position.xyz, n = point.normal.xyz, albedoOverPi = point.albedo.rgb / kPi;
    vec3 origin = position + n * uOffset;
    vec3 planePoint = position + n * finestCell();
    vec3 helper = abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    vec3 tangent = normalize(cross(helper, n));
    vec3 bitangent = cross(n, tangent);
    float cosView = clamp(dot(n, point.view.xyz), 0.0, 1.0);
    vec3 mirrored = n * (2.0 * cosView) - point.view.xyz;
    float mirroredLength = length(mirrored);

    // The lights that can reach the point: its light-grid cell's list (LightGrid::cellOf).
    uvec3 cell = uvec3(clamp(floor((position - uLightGridOrigin) * uLightGridInverseCell), vec3(0.0),
                             vec3(uLightGridCells - 1u)));
    uvec2 lightRange = lightCells[(cell.z * uLightGridCells.y + cell.y) * uLightGridCells.x + cell.x];
    uint lightCount = lightRange.y;

    // Every cone of the point through one traceCone call (the shader's size is what a JIT
    // compiler such as llvmpipe's takes seconds over): cone k < lightCount is the shadow cone
    // (FinalGather::visibility) of the cell's k-th light, the next seven the diffuse cones
    // (RadianceField::gatherDiffuse), the last the specular cone.
    vec3 irradiance = vec3(0.0), gathered = vec3(0.0), specular = vec3(0.0);
    float occlusion = 0.0, weightSum = 0.0;
    for (uint k = 0u; k < lightCount + 8u; ++k) {
        vec3 dir, lightIrradiance = vec3(0.0);
        float tanHalf = uDiffuseTanHalf, maxDistance = 1e30, weight = 0.0, cosine = 0.0;
        if (k < lightCount) {
            // Direct: Σ lights E · cos · visibility (FinalGather::shade(point)), in light order.
            float distance;
            bool infinite;
            if (!lightArrival(lights[lightList[lightRange.x + k]], position, dir, distance, infinite,
                              lightIrradiance)) continue;
            cosine = dot(n, dir);
            if (!(cosine > 0.0)) continue;
            if (!uShadowCones) {
                irradiance += lightIrradiance * cosine;
                continue;
            }
            tanHalf = uTanHalfShadow;
            if (!infinite) maxDistance = length(position + dir * distance - origin) / (1.0 + 3.0 * uTanHalfShadow);
        } else if (k < lightCount + 7u) {
            uint i = k - lightCount;
            dir = n;
            weight = uDiffuseWeights[0];
            if (i > 0u) {
                dir = normalize(n * uDiffuseTilt.x + (tangent * uDiffuseCos[i - 1u] + bitangent * uDiffuseSin[i - 1u]) * uDiffuseTilt.y);
                weight = uDiffuseWeights[1];
            }
        } else {
            // Specular: Schlick(F0, n·v) × the cone along the mirrored view.
            if (!(mirroredLength > 0.0)) continue;
            dir = mirrored / mirroredLength;
            tanHalf = uTanHalfSpecular;
        }
        bool shadow = k < lightCount;
        ConeResult r = traceCone(origin, dir, tanHalf, 0.0, maxDistance, planePoint, n, shadow ? 0.0 : uAoLambda, shadow);
        if (shadow) {
            float v = 1.0 - r.opacity;
            if (v > 0.0) irradiance += lightIrradiance * (cosine * v);
        } else if (k < lightCount + 7u) {
            gathered += r.radiance * weight;
            occlusion += r.occlusion * weight;
            weightSum += weight;
        } else {
            float fresnel = uSpecularF0 + (1.0 - uSpecularF0) * pow(1.0 - cosView, 5.0);
            specular = r.radiance * fresnel;
        }
    }
    vec3 direct = albedoOverPi * irradiance;
    occlusion /= weightSum;
    vec3 indirect = albedoOverPi * gathered;
    float ao = clamp(1.0 - occlusion, 0.0, 1.0);
    vec3 finalColor = point.emission.rgb + direct + indirect + specular;
    parts[index] = GatherParts(vec4(finalColor, 1.0), vec4(direct, 1.0), vec4(indirect, 1.0), vec4(specular, ao));
    countFallbacks();
}
#endif

#ifdef VOX_MODE_SAMPLE
// ---- sample queries (tests): RadianceField::sample(level, p, dir) ----
struct SampleQuery { vec4 positionLevel; vec4 direction; };  // w of positionLevel: the level (as float)
layout(std430, binding = 6) readonly buffer Queries { SampleQuery queries[]; };
layout(std430, binding = 7) writeonly buffer Samples { vec4 samples[]; };
uniform uint uCount;

void main() {
    uint index = gl_GlobalInvocationID.x;
    if (index >= uCount) return;
    SampleQuery q = queries[index];
    // Through sampleLod: an integer level samples that level alone, or, streamed out, the coarser one.
    samples[index] = sampleLod(q.positionLevel.w, q.positionLevel.xyz, q.direction.xyz);
    countFallbacks();
}
#endif
)GLSL";

}  // namespace vox::runtime::detail

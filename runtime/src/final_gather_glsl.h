// The cone-traced final gather compute shader (GLSL 4.50), embedded in the library.
//
// A port of vox::RadianceField::sample / sampleLod / traceCone / gatherDiffuse
// (libvox/src/radiance/radiance_field.cpp), rvol::combineDirectional (formats/src/rvol.cpp),
// vox::lightArrival (libvox/src/lighting/punctual.cpp) and FinalGather::visibility / shade
// (libvox/src/radiance/final_gather.cpp), over the atlases of RvolGpuVolume. Differences from the
// CPU, all below the tests' tolerance (docs/runtime.md):
// - float instead of double;
// - the opacity correction 1 − (1 − a)^(step/diameter) with step/diameter = ½ exactly (as on the
//   CPU, where step = 0.5·diameter) written as a / (1 + sqrt(1 − a)): the same value without the
//   cancellation of 1 − sqrt(1 − a) in float;
// - with VOX_HARDWARE_FILTER the radiance (and the A8 opacity) is filtered by the texture unit,
//   whose weights may be fixed point (8 bits on many GPUs); without it, eight texelFetch per
//   plane with float weights, as the CPU does. Binary level-0 opacity is always fetched
//   (GL_R32UI view, corners with a non-zero word).
// The host prepends "#version 450 core" and the #defines (VOX_MODE_SHADE or VOX_MODE_SAMPLE,
// VOX_HARDWARE_FILTER).
#pragma once

namespace vox::runtime::detail {

inline constexpr const char* kFinalGatherShader = R"GLSL(
layout(local_size_x = 64) in;

// ---- the volume (RvolGpuVolume::bind) ----
layout(binding = 0) uniform sampler3D uRgbAtlas;    // GL_RGB9_E5, GL_LINEAR
layout(binding = 1) uniform usampler3D uWordAtlas;  // the same storage as GL_R32UI
layout(binding = 2) uniform sampler3D uAlphaAtlas;  // GL_R8, GL_LINEAR

struct LevelInfo { uint base; uint bricksPerAxis; uint resolution; uint planes; };
layout(std430, binding = 4) readonly buffer RvolInfo {
    vec4 volOriginSize;   // origin xyz, size
    uvec4 volGeometry;    // depth, N, levelCount, flags (bit 0: binary level-0 opacity)
    vec4 rgbAtlasSize;
    vec4 alphaAtlasSize;
    LevelInfo levels[];
};
layout(std430, binding = 5) readonly buffer RvolIndirection { uint slots[]; };

uvec3 slotTexel(uint slotWord) {
    return uvec3(slotWord & 1023u, (slotWord >> 10) & 1023u, (slotWord >> 20) & 1023u) * volGeometry.y;
}

// Where p falls in a level: the brick's first indirection entry and the continuous texel
// coordinate t in [0, N − 1] inside the brick (RvolReader::sample's convention, which equals
// RadianceField::sample's cell interpolation since bricks share faces).
void locate(uint level, vec3 p, out uint entry, out vec3 t) {
    LevelInfo L = levels[level];
    float cell = volOriginSize.w / float(L.resolution);
    vec3 u = clamp((p - volOriginSize.xyz) / cell - 0.5, vec3(0.0), vec3(float(L.resolution - 1u)));
    float span = float(volGeometry.y - 1u);
    uvec3 b = min(uvec3(floor(u / span)), uvec3(L.bricksPerAxis - 1u));
    t = u - vec3(b) * span;
    uint k = L.bricksPerAxis;
    entry = L.base + ((b.z * k + b.y) * k + b.x) * L.planes;
}

// One RGB plane's radiance at t.
vec3 filterRgb(uint slotWord, vec3 t) {
    vec3 o = vec3(slotTexel(slotWord));
#ifdef VOX_HARDWARE_FILTER
    return texture(uRgbAtlas, (o + t + 0.5) / rgbAtlasSize.xyz).rgb;
#else
    vec3 i = min(floor(t), vec3(float(volGeometry.y - 2u)));
    vec3 f = t - i;
    ivec3 base = ivec3(o + i);
    vec3 sum = vec3(0.0);
    for (int c = 0; c < 8; ++c) {
        ivec3 d = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        float w = (d.x == 1 ? f.x : 1.0 - f.x) * (d.y == 1 ? f.y : 1.0 - f.y) * (d.z == 1 ? f.z : 1.0 - f.z);
        if (w <= 0.0) continue;
        sum += w * texelFetch(uRgbAtlas, base + d, 0).rgb;
    }
    return sum;
#endif
}

// One A8 plane's opacity at t, and its transmittance 1 − opacity, computed so that it is 0 where
// the CPU's opacity (a double sum rounded to float) is exactly 1: combineDirectional's
// log(max(1 − a, 1e-12)) jumps from about −16.6 (1 − a = 2^-24) to −27.6 (a = 1) there, so
// every corner's weight must leave no float error below 1.
vec2 filterAlpha(uint slotWord, vec3 t) {
    vec3 o = vec3(slotTexel(slotWord));
#ifdef VOX_HARDWARE_FILTER
    float a = texture(uAlphaAtlas, (o + t + 0.5) / alphaAtlasSize.xyz).r;
    // The filter's result within two float steps of 1 is an opaque neighbourhood (a sum of
    // weights that does not quite reach 1): fully opaque, as the CPU's float rounding makes it.
    float transmittance = 1.0 - a;
    return transmittance <= exp2(-23.0) ? vec2(1.0, 0.0) : vec2(a, transmittance);
#else
    vec3 i = min(floor(t), vec3(float(volGeometry.y - 2u)));
    vec3 f = t - i;
    ivec3 base = ivec3(o + i);
    float sum = 0.0, transmittance = 0.0;
    for (int c = 0; c < 8; ++c) {
        ivec3 d = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        float w = (d.x == 1 ? f.x : 1.0 - f.x) * (d.y == 1 ? f.y : 1.0 - f.y) * (d.z == 1 ? f.z : 1.0 - f.z);
        if (w <= 0.0) continue;
        float a = texelFetch(uAlphaAtlas, base + d, 0).r;
        sum += w * a;
        transmittance += w * (1.0 - a);
    }
    // Below half a float step under 1 the CPU's opacity rounds to 1.
    return transmittance < exp2(-25.0) ? vec2(1.0, 0.0) : vec2(sum, transmittance);
#endif
}

// Binary level-0 opacity: the trilinear weights of the corners whose RGB9E5 word is not 0.
float filterBinaryAlpha(uint slotWord, vec3 t) {
    vec3 i = min(floor(t), vec3(float(volGeometry.y - 2u)));
    vec3 f = t - i;
    ivec3 base = ivec3(vec3(slotTexel(slotWord)) + i);
    float sum = 0.0;
    for (int c = 0; c < 8; ++c) {
        ivec3 d = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        float w = (d.x == 1 ? f.x : 1.0 - f.x) * (d.y == 1 ? f.y : 1.0 - f.y) * (d.z == 1 ? f.z : 1.0 - f.z);
        if (w <= 0.0) continue;
        if (texelFetch(uWordAtlas, base + d, 0).r != 0u) sum += w;
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

// RadianceField::sample.
vec4 sampleLevel(uint level, vec3 p, vec3 dir) {
    uint entry;
    vec3 t;
    locate(level, p, entry, t);
    if (level == 0u) {
        vec3 rgb = filterRgb(slots[entry], t);
        float a = (volGeometry.w & 1u) != 0u ? filterBinaryAlpha(slots[entry], t) : filterAlpha(slots[entry + 1u], t).x;
        return vec4(rgb, a);
    }
    vec4 facing[3];
    float transmittance[3];
    for (int a = 0; a < 3; ++a) {
        uint channel = uint(2 * a) + (dir[a] < 0.0 ? 1u : 0u);
        vec2 alpha = filterAlpha(slots[entry + 6u + uint(a)], t);
        facing[a] = vec4(filterRgb(slots[entry + channel], t), alpha.x);
        transmittance[a] = alpha.y;
    }
    return combineDirectional(facing, transmittance, dir);
}

// Whether the brick holding p at level is one the GPU does not hold (kMissingBrick: streamed out).
bool missingAt(uint level, vec3 p) {
    uint entry;
    vec3 t;
    locate(level, p, entry, t);
    return slots[entry] == 0x80000000u;
}

// RadianceField::sampleLod; where streaming left the brick at the level missing, the finest
// coarser level present (a residency keeps a brick's coarser cover whenever it keeps the brick).
vec4 sampleLod(float level, vec3 p, vec3 dir) {
    float top = float(volGeometry.z - 1u);
    level = clamp(level, 0.0, top);
    uint lo = uint(floor(level));
    while (lo + 1u < volGeometry.z && missingAt(lo, p)) {
        ++lo;
        level = max(level, float(lo));
    }
    float f = level - float(lo);
    vec4 a = sampleLevel(lo, p, dir);
    if (f <= 0.0 || lo + 1u >= volGeometry.z || missingAt(lo + 1u, p)) return a;
    vec4 b = sampleLevel(lo + 1u, p, dir);
    return a + (b - a) * f;
}

float finestCell() { return volOriginSize.w / float(levels[0].resolution); }

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
        if (clampToPlane) footprint = max(finest, min(footprint, dot(p - planePoint, planeNormal) / 1.5));
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

uniform uint uCount;
uniform uint uLightCount;
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

// FinalGather::visibility.
float visibility(vec3 position, vec3 n, vec3 toLight, float distance, bool infinite) {
    if (!uShadowCones) return 1.0;
    vec3 origin = position + n * uOffset;
    float maxDistance = 1e30;
    if (!infinite) {
        vec3 light = position + toLight * distance;
        maxDistance = length(light - origin) / (1.0 + 3.0 * uTanHalfShadow);
    }
    ConeResult r = traceCone(origin, toLight, uTanHalfShadow, 0.0, maxDistance, position + n * finestCell(), n, 0.0, true);
    return 1.0 - r.opacity;
}

void main() {
    uint index = gl_GlobalInvocationID.x;
    if (index >= uCount) return;
    GatherPoint point = points[index];
    vec3 position = point.position.xyz, n = point.normal.xyz, albedoOverPi = point.albedo.rgb / kPi;

    // Direct: Σ lights E · cos · visibility (FinalGather::shade(point)).
    vec3 irradiance = vec3(0.0);
    for (uint l = 0u; l < uLightCount; ++l) {
        vec3 toLight, e;
        float distance;
        bool infinite;
        if (!lightArrival(lights[l], position, toLight, distance, infinite, e)) continue;
        float cosine = dot(n, toLight);
        if (!(cosine > 0.0)) continue;
        float v = visibility(position, n, toLight, distance, infinite);
        if (!(v > 0.0)) continue;
        irradiance += e * (cosine * v);
    }
    vec3 direct = albedoOverPi * irradiance;

    // Indirect and AO: RadianceField::gatherDiffuse.
    vec3 helper = abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    vec3 tangent = normalize(cross(helper, n));
    vec3 bitangent = cross(n, tangent);
    vec3 origin = position + n * uOffset;
    vec3 planePoint = position + n * finestCell();
    vec3 gathered = vec3(0.0);
    float occlusion = 0.0, weightSum = 0.0;
    for (int i = 0; i < 7; ++i) {
        vec3 dir = n;
        float weight = uDiffuseWeights[0];
        if (i > 0) {
            dir = normalize(n * uDiffuseTilt.x + (tangent * uDiffuseCos[i - 1] + bitangent * uDiffuseSin[i - 1]) * uDiffuseTilt.y);
            weight = uDiffuseWeights[1];
        }
        ConeResult r = traceCone(origin, dir, uDiffuseTanHalf, 0.0, 1e30, planePoint, n, uAoLambda, false);
        gathered += r.radiance * weight;
        occlusion += r.occlusion * weight;
        weightSum += weight;
    }
    occlusion /= weightSum;
    vec3 indirect = albedoOverPi * gathered;
    float ao = clamp(1.0 - occlusion, 0.0, 1.0);

    // Specular: Schlick(F0, n·v) × the cone along the mirrored view.
    vec3 specular = vec3(0.0);
    float cosView = clamp(dot(n, point.view.xyz), 0.0, 1.0);
    vec3 mirrored = n * (2.0 * cosView) - point.view.xyz;
    float mirroredLength = length(mirrored);
    if (mirroredLength > 0.0) {
        vec3 reflected = mirrored / mirroredLength;
        float fresnel = uSpecularF0 + (1.0 - uSpecularF0) * pow(1.0 - cosView, 5.0);
        ConeResult r = traceCone(origin, reflected, uTanHalfSpecular, 0.0, 1e30, planePoint, n, uAoLambda, false);
        specular = r.radiance * fresnel;
    }
    vec3 finalColor = point.emission.rgb + direct + indirect + specular;
    parts[index] = GatherParts(vec4(finalColor, 1.0), vec4(direct, 1.0), vec4(indirect, 1.0), vec4(specular, ao));
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
}
#endif
)GLSL";

}  // namespace vox::runtime::detail

/// @file channels.h
/// @brief Turning a GpuFrame into an 8-bit RGB image: the channels of `voxinspect render`
/// (shaded, color, normal, face-normal, depth, iterations, level) with the same shading, so that
/// voxview's PNGs compare with voxinspect's pixel for pixel.
#pragma once

#include <vox/runtime/camera.h>
#include <vox/runtime/esvo_gpu_raycaster.h>

#include <cstdint>
#include <string>
#include <vector>

namespace vox::runtime {

/// The channel names voxview accepts.
[[nodiscard]] bool isChannel(const std::string& channel);
/// Whether @p channel needs decoded attributes (GpuCastOptions::attributes).
[[nodiscard]] bool channelNeedsAttributes(const std::string& channel);

/// RGB8, row 0 at the top. shaded: Phong under a headlight (ambient 0.1, diffuse 0.9 × albedo,
/// specular 0.25 at exponent 32) from the decoded colours and shading normals; color: the albedo;
/// normal: the shading normal (the face's where there is none) as 127.5·(n + 1); depth: grey
/// from near (255) to far (51); iterations: blue-green-red heat map; level: a palette.
/// @throws vox::UsageError for an unknown channel.
[[nodiscard]] std::vector<std::uint8_t> composeChannel(const GpuFrame& frame, const Camera& camera,
                                                       const std::string& channel);

[[nodiscard]] float srgbToLinear(float v);
[[nodiscard]] float linearToSrgb(float v);

}  // namespace vox::runtime

/// @file channels.h
/// @brief Turning a GpuFrame into an 8-bit RGB image: the channels of `voxinspect render`
/// (vox/base/channels.h) with the same shading, so that voxview's PNGs compare with voxinspect's
/// pixel for pixel.
#pragma once

#include <vox/base/camera.h>
#include <vox/base/channels.h>
#include <vox/runtime/esvo_gpu_raycaster.h>

#include <cstdint>
#include <vector>

namespace vox::runtime {

/// RGB8 of @p channel (vox::composeChannel), row 0 at the top; shaded: vox::shadeHeadlight of
/// the decoded colours and shading normals (the face normal on grey where a voxel has none).
/// @p camera is the one @p frame was rendered with.
[[nodiscard]] std::vector<std::uint8_t> composeChannel(const GpuFrame& frame,
                                                       const PinholeCamera& camera,
                                                       Channel channel);

}  // namespace vox::runtime

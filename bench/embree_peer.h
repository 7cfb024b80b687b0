// Embree 3 as the triangle peer of the ray casters (issue 33): what a user compares a ray caster
// with. Only bench/raycast_peer uses it, and only where CMake found Embree (LIBVOX_HAVE_EMBREE);
// the Embree headers stay in embree_peer.cpp.
#pragma once

#include <vox/raycast.h>
#include <vox/scene.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace bench {

/// One image of primary rays (or one set of rays) cast by Embree.
struct EmbreeImage {
    std::vector<float> depth;  ///< per ray: distance along the (unit) ray; +inf where it missed
    std::uint64_t hits = 0;
    double seconds = 0;  ///< wall time of the cast alone (no ray set-up, no BVH build)
};

/// The scene's static triangles (as TriangleRayCaster takes them) in an Embree scene built once,
/// cast with single rays (rtcIntersect1) in parallel pixel tiles through TBB, so a ThreadLimit
/// bounds the threads as it bounds libvox's casters.
class EmbreePeer {
public:
    /// Builds the BVH at RTC_BUILD_QUALITY_HIGH (SAH with spatial splits: Embree's fastest to
    /// trace, the strongest peer). @p threads: Embree's build threads (0: all). @throws
    /// std::runtime_error.
    EmbreePeer(const vox::Scene& scene, int threads);
    ~EmbreePeer();
    EmbreePeer(const EmbreePeer&) = delete;
    EmbreePeer& operator=(const EmbreePeer&) = delete;

    /// One ray per pixel, the very rays camera.rayThrough gives (rounded to float), prepared
    /// before the clock starts; the timed part is rtcIntersect1 and the depth write per pixel.
    [[nodiscard]] EmbreeImage render(const vox::PinholeCamera& camera) const;
    /// Ray i from origins[3i…3i+2] along directions[3i…3i+2] (unit), in chunks of 256 rays
    /// through TBB; the timed part is rtcIntersect1 and the depth write per ray.
    [[nodiscard]] EmbreeImage cast(const std::vector<float>& origins,
                                   const std::vector<float>& directions) const;

    [[nodiscard]] double buildSeconds() const noexcept { return buildSeconds_; }
    [[nodiscard]] std::uint64_t triangleCount() const noexcept { return triangles_; }
    [[nodiscard]] static std::string version();
    [[nodiscard]] static const char* buildQuality() { return "high"; }

private:
    struct Handles;
    std::unique_ptr<Handles> handles_;
    double buildSeconds_ = 0;
    std::uint64_t triangles_ = 0;
};

}  // namespace bench

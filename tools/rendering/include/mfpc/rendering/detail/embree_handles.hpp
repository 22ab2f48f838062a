#pragma once

// Owning handles for Embree 3 objects, shared by the virtual scanner and the renderer. Embree's
// headers stay inside tools/src: no public header of mfpc_tools includes them.

#include <limits>
#include <memory>
#include <string>

#include <embree3/rtcore.h>

namespace mfpc::embree {

struct DeviceDeleter {
    void operator()(RTCDevice device) const { rtcReleaseDevice(device); }
};
struct SceneDeleter {
    void operator()(RTCScene scene) const { rtcReleaseScene(scene); }
};
struct GeometryDeleter {
    void operator()(RTCGeometry geometry) const { rtcReleaseGeometry(geometry); }
};
using Device = std::unique_ptr<RTCDeviceTy, DeviceDeleter>;
using Scene = std::unique_ptr<RTCSceneTy, SceneDeleter>;
// Held until attached to a scene (which keeps its own reference), so a throw on the way leaks nothing.
using Geometry = std::unique_ptr<RTCGeometryTy, GeometryDeleter>;

// Embree records an error per thread; check() turns the calling thread's into mfpc::Error, so the
// scene building (all on the caller's thread) fails with one line, not a silent miss. Ray queries
// on worker threads record none for a committed scene.
Device make_device();
Scene make_scene(RTCDevice device);

// Throws mfpc::Error naming `what` when the device has recorded an error since the last check.
void check(RTCDevice device, const std::string& what);

// A ray from `origin` along `direction` (need not be unit), hitting from t = near to infinity.
inline RTCRayHit make_ray(const float origin[3], const float direction[3], float near = 0.0f)
{
    RTCRayHit ray{};
    ray.ray.org_x = origin[0];
    ray.ray.org_y = origin[1];
    ray.ray.org_z = origin[2];
    ray.ray.dir_x = direction[0];
    ray.ray.dir_y = direction[1];
    ray.ray.dir_z = direction[2];
    ray.ray.tnear = near;
    ray.ray.tfar = std::numeric_limits<float>::infinity();
    ray.ray.mask = 0xFFFFFFFFu;
    ray.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    ray.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return ray;
}

}  // namespace mfpc::embree

#include "mfpc/rendering/detail/embree_handles.hpp"

#include "mfpc/core/error.hpp"

namespace mfpc::embree {

Device make_device()
{
    // Embree shares TBB's scheduler with the caller, so tbb::global_control limits its builds too.
    Device device(rtcNewDevice("verbose=0"));
    if (!device) {
        throw Error("embree", "cannot create a device (" +
                                  std::string(rtcGetDeviceError(nullptr) == RTC_ERROR_UNSUPPORTED_CPU
                                                  ? "unsupported CPU"
                                                  : "out of memory or bad configuration") +
                                  ")");
    }
    return device;
}

Scene make_scene(RTCDevice device)
{
    Scene scene(rtcNewScene(device));
    check(device, "scene");
    return scene;
}

void check(RTCDevice device, const std::string& what)
{
    const RTCError code = rtcGetDeviceError(device);
    if (code == RTC_ERROR_NONE) return;
    const char* reason = "unknown error";
    switch (code) {
        case RTC_ERROR_INVALID_ARGUMENT: reason = "invalid argument"; break;
        case RTC_ERROR_INVALID_OPERATION: reason = "invalid operation"; break;
        case RTC_ERROR_OUT_OF_MEMORY: reason = "out of memory"; break;
        case RTC_ERROR_UNSUPPORTED_CPU: reason = "unsupported CPU"; break;
        case RTC_ERROR_CANCELLED: reason = "cancelled"; break;
        default: break;
    }
    throw Error("embree: " + what, reason);
}

}  // namespace mfpc::embree

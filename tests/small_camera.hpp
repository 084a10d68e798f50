#pragma once
// A quarter-size camera (960x480, same 60 deg field of view as the default 3840x1920) that keeps
// simulator tests quick; the rendering path is the same as at full size.

#include "calibd/core/camera/camera_model.hpp"

namespace calibd::testing {

inline CameraIntrinsics SmallCamera() {
  CameraIntrinsics k;
  k.width = 960;
  k.height = 480;
  k.fx = k.fy = 831.0;
  k.cx = 479.5;
  k.cy = 239.5;
  return k;
}

}  // namespace calibd::testing

// meshcvt tests: what the GPU tests share. They need a Vulkan device (lavapipe from
// mesa-vulkan-drivers is enough); without one they fail with a message saying so, unless
// MESHCVT_SKIP_GPU_TESTS=1 skips them.
#pragma once

#include <doctest/doctest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "meshcvt/device.h"
#include "meshcvt/error.h"

namespace meshcvt::test {

/// Whether MESHCVT_SKIP_GPU_TESTS=1 asks to skip the GPU tests (doctest::skip(skip_gpu_tests())).
inline bool skip_gpu_tests() {
  const char* value = std::getenv("MESHCVT_SKIP_GPU_TESTS");
  return value && std::strcmp(value, "1") == 0;
}

/// The device the GPU tests run on: the one "gpu" picks (lavapipe on CI). Fails the test, saying
/// how to get one, when there is none.
inline uint32_t gpu_test_device() {
  std::vector<DeviceInfo> devices;
  try {
    devices = list_devices();
  } catch (const DeviceError& e) {
    FAIL("GPU tests need a Vulkan device (" << e.what() << "); or set MESHCVT_SKIP_GPU_TESTS=1");
  }
  if (devices.empty())
    FAIL("GPU tests need a Vulkan device: install mesa-vulkan-drivers (lavapipe), or set MESHCVT_SKIP_GPU_TESTS=1");
  DeviceChoice choice = resolve_device("gpu", devices);
  REQUIRE(choice.use_gpu);
  return static_cast<uint32_t>(choice.device_index);
}

/// Sets an environment variable for one scope and restores it after ($MESHCVT_DEVICE,
/// $MESHCVT_GPU_FAULT, ...).
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value)
      setenv(name, value, 1);
    else
      unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_)
      setenv(name_, old_->c_str(), 1);
    else
      unsetenv(name_);
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

}  // namespace meshcvt::test

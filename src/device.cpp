// meshcvt: listing Vulkan devices and resolving --device requests (see meshcvt/device.h for the
// rule). The Vulkan work is in host/; this file only ranks and explains.
#include "meshcvt/device.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <thread>

#include "meshcvt/error.h"
#include "vk_context.h"
#include "vk_rule_check.h"
#include "vk_selftest.h"

namespace meshcvt {

namespace {

struct Request {
  enum Kind { automatic, cpu, gpu, gpu_index } kind = automatic;
  uint32_t index = 0;
};

// "" -> $MESHCVT_DEVICE or "auto"; then the syntax, before any Vulkan call.
Request parse_request(const std::string& request) {
  std::string text = request;
  bool from_environment = false;
  if (text.empty()) {
    const char* value = std::getenv("MESHCVT_DEVICE");
    if (value && *value) {
      text = value;
      from_environment = true;
    } else {
      text = "auto";
    }
  }
  if (text == "auto") return {Request::automatic, 0};
  if (text == "cpu") return {Request::cpu, 0};
  if (text == "gpu") return {Request::gpu, 0};
  if (text.size() > 4 && text.size() <= 4 + 9 && text.compare(0, 4, "gpu:") == 0 &&
      text.find_first_not_of("0123456789", 4) == std::string::npos)
    return {Request::gpu_index, static_cast<uint32_t>(std::stoul(text.substr(4)))};
  throw OptionError("unknown device \"" + text + "\"" + (from_environment ? " (from $MESHCVT_DEVICE)" : "") +
                    ": expected auto, cpu, gpu or gpu:N (N = a device index from 'meshcvt devices')");
}

// Lower is better: what "gpu" prefers.
int type_rank(const std::string& type) {
  if (type == "discrete") return 0;
  if (type == "integrated") return 1;
  if (type == "virtual") return 2;
  if (type == "other") return 3;
  return 4;  // "cpu": a software rasterizer such as lavapipe, slower than the CPU engine
}

std::string describe(const DeviceInfo& device) {
  return "gpu:" + std::to_string(device.index) + " " + device.name + " (" + device.type + ")";
}

DeviceChoice gpu_choice(const DeviceInfo& device) { return {true, static_cast<int>(device.index), describe(device), ""}; }

DeviceChoice cpu_choice(std::string notice = {}) { return {false, -1, "cpu", std::move(notice)}; }

const char* const kNoDevice =
    "no Vulkan device found; install a driver, e.g. mesa-vulkan-drivers for the CPU device lavapipe";

DeviceChoice resolve(const Request& request, const std::vector<DeviceInfo>& devices) {
  switch (request.kind) {
    case Request::cpu:
      return cpu_choice();
    case Request::gpu_index: {
      if (request.index >= devices.size()) {
        std::string known;
        for (const DeviceInfo& d : devices) known += (known.empty() ? "" : ", ") + describe(d);
        throw DeviceError("gpu:" + std::to_string(request.index) + ": no such Vulkan device; " +
                          (devices.empty() ? std::string(kNoDevice) : "this machine has " + known));
      }
      const DeviceInfo& device = devices[request.index];
      if (!device.usable)
        throw DeviceError(describe(device) + " cannot run meshcvt: it lacks " + device.missing_features);
      return gpu_choice(device);
    }
    case Request::gpu: {
      const DeviceInfo* best = nullptr;
      for (const DeviceInfo& d : devices)
        if (d.usable && (!best || type_rank(d.type) < type_rank(best->type))) best = &d;
      if (best) return gpu_choice(*best);
      if (devices.empty()) throw DeviceError(kNoDevice);
      std::string why;
      for (const DeviceInfo& d : devices) why += (why.empty() ? "" : "; ") + describe(d) + " lacks " + d.missing_features;
      throw DeviceError("no Vulkan device can run meshcvt: " + why);
    }
    case Request::automatic: {
      const DeviceInfo* best = nullptr;
      const DeviceInfo* unusable_gpu = nullptr;
      for (const DeviceInfo& d : devices) {
        if (type_rank(d.type) > 1) continue;  // auto takes real GPUs only
        if (!d.usable) {
          if (!unusable_gpu) unusable_gpu = &d;
        } else if (!best || type_rank(d.type) < type_rank(best->type)) {
          best = &d;
        }
      }
      if (best) {
        DeviceChoice choice = gpu_choice(*best);
        choice.automatic = true;
        return choice;
      }
      if (unusable_gpu)
        return cpu_choice("using the CPU engine: " + describe(*unusable_gpu) + " lacks " + unusable_gpu->missing_features);
      if (devices.empty()) return cpu_choice("using the CPU engine: no Vulkan device found");
      return cpu_choice();  // only CPU-type devices (lavapipe): the CPU engine is faster, say nothing
    }
  }
  return cpu_choice();
}

// Whether the machine may have a hardware GPU: a DRM render node (Mesa's and AMD/Intel drivers),
// NVIDIA's device nodes, or WSL's /dev/dxg. $MESHCVT_PROBE_VULKAN=1 skips the check (e.g. a
// container that hides /dev but forwards a GPU some other way). Outside Linux: always true.
bool gpu_device_node_present() {
#ifdef __linux__
  if (const char* force = std::getenv("MESHCVT_PROBE_VULKAN"); force && std::string(force) == "1") return true;
  std::error_code ec;
  for (const char* node : {"/dev/nvidiactl", "/dev/nvidia0", "/dev/dxg"})
    if (std::filesystem::exists(node, ec)) return true;
  for (const auto& entry : std::filesystem::directory_iterator("/dev/dri", ec))
    if (entry.path().filename().string().rfind("renderD", 0) == 0) return true;
  return false;
#else
  return true;
#endif
}

}  // namespace

std::vector<DeviceInfo> list_devices() {
  // Listing needs no validation: it creates nothing that could be misused.
  std::vector<VkPhysicalDevice> physical = vk::shared_instance(/*validation=*/false).physical_devices();
  std::vector<DeviceInfo> devices;
  devices.reserve(physical.size());
  for (uint32_t i = 0; i < physical.size(); ++i) devices.push_back(vk::describe_device(physical[i], i));
  return devices;
}

DeviceChoice resolve_device(const std::string& request, const std::vector<DeviceInfo>& devices) {
  return resolve(parse_request(request), devices);
}

DeviceChoice resolve_device(const std::string& request) {
  const Request parsed = parse_request(request);
  if (parsed.kind == Request::cpu) return cpu_choice();
  if (parsed.kind == Request::automatic) {
    // Loading the Vulkan loader and its drivers costs ~25-100 ms and tens of MB (lavapipe pulls in
    // LLVM), a large part of a small job. "auto" only ever picks a hardware GPU, and on Linux every
    // hardware GPU driver exposes a device node; without one the answer is the CPU engine.
    if (!gpu_device_node_present()) return cpu_choice();
    std::vector<DeviceInfo> devices;
    try {
      devices = list_devices();
    } catch (const DeviceError& e) {
      return cpu_choice(std::string("using the CPU engine: ") + e.what());
    }
    return resolve(parsed, devices);
  }
  return resolve(parsed, list_devices());
}

size_t auto_gpu_min_faces(unsigned threads) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());  // as WorkerPool
  return kAutoGpuMinFaces * std::max(1u, threads / 2);
}

DeviceChoice resolve_device_for_mesh(const std::string& request, size_t faces, unsigned threads) {
  if (faces < auto_gpu_min_faces(threads) && parse_request(request).kind == Request::automatic) return cpu_choice();
  return resolve_device(request);
}

double self_test_device(uint32_t index) {
  const auto start = std::chrono::steady_clock::now();
  const uint64_t messages_before = vk::validation_message_count();
  {
    vk::Context context(index);
    vk::run_self_test(context);
    vk::check_boundary_rule(context);
  }
  // With MESHCVT_VALIDATION=1 a validation message fails the test too: the layer found misuse.
  const uint64_t messages = vk::validation_message_count() - messages_before;
  if (messages > 0)
    throw DeviceError("GPU self-test on gpu:" + std::to_string(index) + ": the Vulkan validation layer reported " +
                      std::to_string(messages) + " message(s) (printed above)");
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace meshcvt

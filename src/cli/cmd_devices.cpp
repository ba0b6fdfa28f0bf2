// meshcvt CLI: `meshcvt devices [--json] [--check]` lists the Vulkan devices, what meshcvt can
// use them for, and which engine --device auto / gpu would pick; --check runs the GPU self-test
// on every usable device.
#include <algorithm>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "cli/command.h"
#include "cli/json.h"
#include "meshcvt/device.h"
#include "meshcvt/error.h"

namespace meshcvt::cli {

namespace {

struct Options {
  bool json = false;
  bool check = false;
};

struct SelfTest {
  bool ran = false, passed = false;
  double seconds = 0;
  std::string error;
};

std::string mib_text(uint64_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

std::vector<std::string> split_list(const std::string& list) {
  std::vector<std::string> items;
  for (size_t start = 0; start < list.size();) {
    size_t end = list.find(", ", start);
    if (end == std::string::npos) end = list.size();
    items.push_back(list.substr(start, end - start));
    start = end + 2;
  }
  return items;
}

std::string choice_text(const std::string& request, const std::vector<DeviceInfo>& devices) {
  try {
    DeviceChoice choice = resolve_device(request, devices);
    return choice.notice.empty() ? choice.description : choice.description + " (" + choice.notice + ")";
  } catch (const Error& e) {
    return std::string("none (") + e.what() + ")";
  }
}

void print_text(const std::vector<DeviceInfo>& devices, const std::vector<SelfTest>& tests) {
  std::printf("%zu Vulkan device%s\n", devices.size(), devices.size() == 1 ? "" : "s");
  for (size_t i = 0; i < devices.size(); ++i) {
    const DeviceInfo& d = devices[i];
    std::printf("\ngpu:%u  %s\n", d.index, d.name.c_str());
    std::printf("  type                       %s\n", d.type.c_str());
    std::printf("  driver                     %s%s%s\n", d.driver_name.empty() ? "(unnamed)" : d.driver_name.c_str(),
                d.driver_info.empty() ? "" : ", ", d.driver_info.c_str());
    std::printf("  Vulkan API                 %s\n", d.api_version.c_str());
    std::string heaps;
    for (size_t h = 0; h < d.heap_sizes.size(); ++h)
      heaps += (h ? ", " : "") + mib_text(d.heap_sizes[h]) + (d.heap_device_local[h] ? " device-local" : " host");
    std::printf("  memory heaps               %s\n", heaps.c_str());
    std::printf("  maxStorageBufferRange      %s (%llu bytes)\n", mib_text(d.max_storage_buffer_range).c_str(),
                static_cast<unsigned long long>(d.max_storage_buffer_range));
    std::printf("  subgroup size              %u\n", d.subgroup_size);
    std::printf("  maxComputeWorkGroupCount.x %u\n", d.max_workgroup_count_x);
    if (d.usable)
      std::printf("  meshcvt                    usable (shaderInt64, shaderBufferInt64Atomics, bufferDeviceAddress, subgroup ballot)\n");
    else
      std::printf("  meshcvt                    not usable: lacks %s\n", d.missing_features.c_str());
    if (tests[i].ran) {
      if (tests[i].passed)
        std::printf("  self-test                  passed (%.2f s)\n", tests[i].seconds);
      else
        std::printf("  self-test                  FAILED: %s\n", tests[i].error.c_str());
    }
  }
  std::string automatic = choice_text("auto", devices);
  if (automatic.rfind("gpu:", 0) == 0)
    automatic += ", for meshes of " + std::to_string(auto_gpu_min_faces(0)) + " faces or more (" +
                 std::to_string(kAutoGpuMinFaces) + " per two CPU threads, here " +
                 std::to_string(std::max(1u, std::thread::hardware_concurrency())) + "; smaller: cpu)";
  std::printf("\n--device auto: %s\n--device gpu:  %s\n", automatic.c_str(), choice_text("gpu", devices).c_str());
}

void print_json(const std::vector<DeviceInfo>& devices, const std::vector<SelfTest>& tests) {
  Json json;
  json.begin_object().begin_array("devices");
  for (size_t i = 0; i < devices.size(); ++i) {
    const DeviceInfo& d = devices[i];
    json.begin_object()
        .value("index", d.index)
        .value("name", d.name)
        .value("type", d.type)
        .value("driver_name", d.driver_name)
        .value("driver_info", d.driver_info)
        .value("api_version", d.api_version)
        .begin_array("heaps");
    for (size_t h = 0; h < d.heap_sizes.size(); ++h)
      json.begin_object().value("bytes", d.heap_sizes[h]).value("device_local", bool(d.heap_device_local[h])).end_object();
    json.end_array()
        .value("max_storage_buffer_range", d.max_storage_buffer_range)
        .value("subgroup_size", d.subgroup_size)
        .value("max_workgroup_count_x", d.max_workgroup_count_x)
        .value("usable", d.usable)
        .begin_array("missing_features");
    for (const std::string& m : split_list(d.missing_features)) json.item(m);
    json.end_array();
    if (tests[i].ran) {
      json.begin_object("self_test").value("passed", tests[i].passed).value("seconds", tests[i].seconds);
      if (!tests[i].passed) json.value("error", tests[i].error);
      json.end_object();
    }
    json.end_object();
  }
  json.end_array();
  json.begin_object("selection").value("auto", choice_text("auto", devices)).value("gpu", choice_text("gpu", devices));
  json.end_object().end_object();
  std::fputs(json.str().c_str(), stdout);
}

void run(const Options& options) {
  std::vector<DeviceInfo> devices = list_devices();  // throws DeviceError without a loader: exit 1
  if (devices.empty())
    throw DeviceError("no Vulkan device found; install a driver, e.g. mesa-vulkan-drivers for the CPU device lavapipe");
  std::vector<SelfTest> tests(devices.size());
  size_t failures = 0;
  if (options.check) {
    for (size_t i = 0; i < devices.size(); ++i) {
      if (!devices[i].usable) continue;
      tests[i].ran = true;
      try {
        tests[i].seconds = self_test_device(devices[i].index);
        tests[i].passed = true;
      } catch (const DeviceError& e) {
        tests[i].error = e.what();
      }
      failures += tests[i].passed ? 0 : 1;
    }
  }
  if (options.json)
    print_json(devices, tests);
  else
    print_text(devices, tests);
  std::fflush(stdout);
  if (failures > 0) throw DeviceError("GPU self-test failed on " + std::to_string(failures) + " device(s)");
}

const RegisterCommand reg(90, [](CLI::App& app) {
  static Options options;
  CLI::App* sub = app.add_subcommand("devices", "List Vulkan compute devices and whether meshcvt can use them");
  sub->add_flag("--json", options.json, "Print JSON instead of text");
  sub->add_flag("--check", options.check,
                "Run the GPU self-test on every usable device: 64-bit atomics through buffer device addresses, and "
                "the boundary rule bit for bit against the CPU engine's");
  sub->callback([] { run(options); });
});

}  // namespace

}  // namespace meshcvt::cli

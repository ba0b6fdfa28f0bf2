// meshcvt: compute devices. Lists the Vulkan devices of this machine and resolves a --device
// request ("auto", "cpu", "gpu", "gpu:N") into the engine that will run. No Vulkan types here:
// the Vulkan code lives in host/ and this header is all a user of the library sees.
//
// Vulkan is loaded at run time (libvulkan.so.1), so meshcvt runs on machines without it: the CPU
// engine needs nothing. Environment variables read:
//   MESHCVT_DEVICE          default for an empty request (see resolve_device)
//   MESHCVT_VALIDATION=1    enable VK_LAYER_KHRONOS_validation for GPU work (an error if missing)
//   MESHCVT_GPU_TIMEOUT     seconds a GPU wait may take before the run fails (default 60)
//   MESHCVT_VULKAN_LIBRARY  path of the Vulkan loader to open instead of libvulkan.so.1
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace meshcvt {

/// One Vulkan physical device, as the driver describes it.
struct DeviceInfo {
  uint32_t index = 0;        ///< position in the loader's device list: the N of "gpu:N"
  std::string name;          ///< e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string type;          ///< "discrete", "integrated", "virtual", "cpu" (e.g. lavapipe) or "other"
  std::string driver_name;   ///< e.g. "llvmpipe"; empty when the driver does not say
  std::string driver_info;   ///< e.g. "Mesa 22.3.6 (LLVM 15.0.6)"
  std::string api_version;   ///< Vulkan version the device supports, "MAJOR.MINOR.PATCH"
  std::vector<uint64_t> heap_sizes;     ///< bytes, one per memory heap
  std::vector<bool> heap_device_local;  ///< per heap: VK_MEMORY_HEAP_DEVICE_LOCAL_BIT
  uint64_t max_storage_buffer_range = 0;  ///< bytes one storage-buffer binding may span
  uint32_t subgroup_size = 0;             ///< invocations per subgroup (0 when unknown)
  uint32_t max_workgroup_count_x = 0;     ///< maxComputeWorkGroupCount[0]
  /// True when meshcvt can run on it: Vulkan 1.2, a compute queue, and the features
  /// shaderInt64, shaderBufferInt64Atomics, bufferDeviceAddress, and subgroup ballot operations
  /// in compute shaders.
  bool usable = false;
  /// Why not usable: the missing items, comma-separated (e.g. "shaderInt64, bufferDeviceAddress");
  /// empty when usable.
  std::string missing_features;
};

/// Every Vulkan device the loader reports, in the loader's order (index = position).
/// Returns an empty list when the loader works but reports no device (no driver installed).
/// Throws DeviceError when the Vulkan loader cannot be opened; the message says what to install.
std::vector<DeviceInfo> list_devices();

/// Which engine runs, from a --device request.
struct DeviceChoice {
  bool use_gpu = false;      ///< false: the CPU engine
  int device_index = -1;     ///< DeviceInfo::index of the chosen GPU; -1 for the CPU engine
  std::string description;   ///< "cpu", or "gpu:N NAME (TYPE)"
  std::string notice;        ///< one line for the user when "auto" fell back to the CPU; else empty
  /// The GPU was chosen by "auto": should its engine fail, the CPU engine takes over
  /// (ClusterOptions::cpu_fallback).
  bool automatic = false;
};

/// Resolves a device request against the devices of this machine (calls list_devices() only when
/// the request needs it, i.e. not for "cpu").
///
/// The rule:
///   ""      -> the value of $MESHCVT_DEVICE if set and not empty, else "auto".
///   "cpu"   -> the CPU engine.
///   "gpu"   -> the best usable Vulkan device: discrete > integrated > virtual > other > cpu-type
///              (e.g. lavapipe); the lowest index among equals. DeviceError when there is none,
///              naming each device and what it lacks.
///   "gpu:N" -> device N (decimal). DeviceError when N is out of range or the device is not usable,
///              naming why.
///   "auto"  -> the best usable discrete or integrated GPU if there is one, else the CPU engine.
///              A CPU-type Vulkan device (lavapipe) is never chosen by "auto", only when asked for.
///              When it falls back because there is no Vulkan loader, no device, or a GPU that is
///              not usable, `notice` says so in one line; a machine with only CPU-type devices
///              falls back silently. On Linux, a machine without a GPU device node (/dev/dri/renderD*,
///              /dev/nvidia*, /dev/dxg) falls back silently without loading Vulkan at all (it
///              costs 25-100 ms); $MESHCVT_PROBE_VULKAN=1 probes anyway. A GPU it picks is marked
///              `automatic`: cluster() hands the job to the CPU engine if that GPU's engine fails.
///   other   -> OptionError listing the accepted forms (naming $MESHCVT_DEVICE when it came from there).
DeviceChoice resolve_device(const std::string& request);

/// Under "auto", the fewest faces for a GPU per two CPU threads of the CPU engine (and the fewest at
/// one or two threads): auto_gpu_min_faces.
constexpr size_t kAutoGpuMinFaces = 1000000;

/// The fewest faces for which "auto" takes a GPU when the CPU engine would run `threads` threads
/// (0 = one per core): kAutoGpuMinFaces * max(1, threads / 2), e.g. 1M faces at 2 threads, 8M at 16.
/// Why: a GPU run pays about 0.15-0.4 s for the Vulkan instance, the device and the uploads, and
/// saves only part of the iterations, which the CPU engine spreads over its threads; the
/// initialization, reading and writing cost the same on both. Measured on an H200 with `meshcvt
/// cluster -n 10000`, whole command (bench/RESULTS.md, "GPU engine", thirty-eighth session): at 2
/// threads the GPU was faster from 1.2M faces (1.30-1.41 s against 1.52-1.69 s), at 4 threads about
/// even at 4.8M and slower at 1.2M, at 8 even at 4.8M and faster at 19.3M (14.6-15.0 s against
/// 15.1-15.7 s), at 16 even at 4.8M and at 19.3M; 75k and 300k faces were slower on the GPU at
/// every thread count (by 0.03-0.2 s).
size_t auto_gpu_min_faces(unsigned threads);

/// resolve_device(request) for a mesh of `faces` faces clustered on `threads` CPU threads (0 = one
/// per core): as there, except that "auto" (also from $MESHCVT_DEVICE or "") takes the CPU engine
/// for fewer than auto_gpu_min_faces(threads) faces without probing for devices. "gpu" and "gpu:N"
/// are taken as asked, whatever the size.
DeviceChoice resolve_device_for_mesh(const std::string& request, size_t faces, unsigned threads = 0);

/// Same rule against a given device list (no Vulkan calls, except that "" still reads
/// $MESHCVT_DEVICE). `devices` stands for the machine's list; used by `meshcvt devices` and tests.
DeviceChoice resolve_device(const std::string& request, const std::vector<DeviceInfo>& devices);

/// Runs a small compute self-test on Vulkan device `index`: 64-bit integer atomics through buffer
/// device addresses, across several dispatches separated by barriers, with the sums checked exactly
/// on the host; then the boundary rule's shader on 65536 cases placed on roundings and subnormals,
/// every result compared bit for bit with the CPU engine's rule (what makes the GPU engine's labels
/// the CPU engine's). Returns the seconds it took (device setup included). Throws DeviceError when
/// the device cannot be opened, computes a wrong result (the message names expected and actual
/// values), or, with MESHCVT_VALIDATION=1, when the validation layer reported any message meanwhile.
double self_test_device(uint32_t index);

}  // namespace meshcvt

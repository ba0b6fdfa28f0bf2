// meshcvt Vulkan host layer: loading Vulkan (volk), the instance and its validation messenger,
// describing physical devices, and opening one logical device (Context).
#include "vk_context.h"

#include <dlfcn.h>

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>

#include "meshcvt/error.h"
#include "vk_errors.h"

namespace meshcvt::vk {

namespace {

const char* const kValidationLayer = "VK_LAYER_KHRONOS_validation";
const char* const kInstallHint =
    "install libvulkan1 and a driver, e.g. mesa-vulkan-drivers for the CPU device lavapipe";

std::mutex g_load_mutex;
bool g_loaded = false;
// Instance-level pointers are process globals in volk; creating instances is serialized so that
// two threads never write them at once (they get the same trampolines anyway).
std::mutex g_instance_mutex;
std::atomic<uint64_t> g_validation_messages{0};
std::atomic<int> g_validation_muted{0};

VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT /*types*/,
                                                     const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                     void* /*user*/) {
  g_validation_messages.fetch_add(1, std::memory_order_relaxed);
  if (g_validation_muted.load(std::memory_order_relaxed) > 0) return VK_FALSE;
  const char* level = (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) ? "error" : "warning";
  std::fprintf(stderr, "meshcvt: vulkan validation %s: %s\n", level,
               data && data->pMessage ? data->pMessage : "(no message)");
  return VK_FALSE;  // never abort the call: the message is enough, and the count fails the tests
}

bool has_layer(const char* name) {
  uint32_t count = 0;
  check(vkEnumerateInstanceLayerProperties(&count, nullptr), "vkEnumerateInstanceLayerProperties");
  std::vector<VkLayerProperties> layers(count);
  check(vkEnumerateInstanceLayerProperties(&count, layers.data()), "vkEnumerateInstanceLayerProperties");
  for (uint32_t i = 0; i < count; ++i)
    if (std::strcmp(layers[i].layerName, name) == 0) return true;
  return false;
}

bool has_instance_extension(const char* layer, const char* name) {
  uint32_t count = 0;
  check(vkEnumerateInstanceExtensionProperties(layer, &count, nullptr), "vkEnumerateInstanceExtensionProperties");
  std::vector<VkExtensionProperties> extensions(count);
  check(vkEnumerateInstanceExtensionProperties(layer, &count, extensions.data()),
        "vkEnumerateInstanceExtensionProperties");
  for (uint32_t i = 0; i < count; ++i)
    if (std::strcmp(extensions[i].extensionName, name) == 0) return true;
  return false;
}

bool has_device_extension(VkPhysicalDevice physical, const char* name) {
  uint32_t count = 0;
  check(vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr),
        "vkEnumerateDeviceExtensionProperties");
  std::vector<VkExtensionProperties> extensions(count);
  check(vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, extensions.data()),
        "vkEnumerateDeviceExtensionProperties");
  for (uint32_t i = 0; i < count; ++i)
    if (std::strcmp(extensions[i].extensionName, name) == 0) return true;
  return false;
}

std::string version_string(uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." +
         std::to_string(VK_API_VERSION_PATCH(v));
}

const char* type_name(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

// The first queue family that can run compute work; UINT32_MAX when there is none. The first is
// usually the universal queue, which every driver schedules at full priority.
uint32_t compute_queue_family(VkPhysicalDevice physical) {
  uint32_t count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, nullptr);
  std::vector<VkQueueFamilyProperties> families(count);
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, families.data());
  for (uint32_t i = 0; i < count; ++i)
    if ((families[i].queueFlags & VK_QUEUE_COMPUTE_BIT) && families[i].queueCount > 0) return i;
  return UINT32_MAX;
}

double timeout_from_environment() {
  const char* text = std::getenv("MESHCVT_GPU_TIMEOUT");
  if (!text || !*text) return 60.0;
  char* end = nullptr;
  double seconds = std::strtod(text, &end);
  if (end == text || *end != '\0' || !(seconds > 0) || !std::isfinite(seconds))
    throw OptionError(std::string("MESHCVT_GPU_TIMEOUT=") + text + ": expected a number of seconds > 0");
  return seconds;
}

}  // namespace

bool vulkan_loaded() {
  std::lock_guard<std::mutex> lock(g_load_mutex);
  return g_loaded;
}

void load_vulkan() {
  std::lock_guard<std::mutex> lock(g_load_mutex);
  if (g_loaded) return;
  const char* path = std::getenv("MESHCVT_VULKAN_LIBRARY");
  if (path && *path) {
    // Never dlclose'd: volk keeps pointers into it for the life of the process.
    void* library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!library) {
      const char* why = dlerror();
      throw DeviceError(std::string("no Vulkan loader: cannot open MESHCVT_VULKAN_LIBRARY=") + path + " (" +
                        (why ? why : "unknown reason") + ")", kInstallHint);
    }
    auto get_proc = reinterpret_cast<PFN_vkGetInstanceProcAddr>(dlsym(library, "vkGetInstanceProcAddr"));
    if (!get_proc)
      throw DeviceError(std::string("no Vulkan loader: ") + path + " has no vkGetInstanceProcAddr", kInstallHint);
    volkInitializeCustom(get_proc);
  } else if (volkInitialize() != VK_SUCCESS) {
    throw DeviceError(std::string("no Vulkan loader: libvulkan.so.1 cannot be opened"), kInstallHint);
  }
  // Vulkan 1.0 loaders cannot create the 1.2 instance meshcvt needs.
  if (!vkEnumerateInstanceVersion)
    throw DeviceError(std::string("the Vulkan loader is version 1.0; meshcvt needs 1.1 or newer"), kInstallHint);
  g_loaded = true;
}

uint64_t validation_message_count() { return g_validation_messages.load(std::memory_order_relaxed); }

bool validation_requested() {
  const char* value = std::getenv("MESHCVT_VALIDATION");
  return value && *value && std::strcmp(value, "0") != 0;
}

ValidationMessagesMuted::ValidationMessagesMuted() { g_validation_muted.fetch_add(1); }
ValidationMessagesMuted::~ValidationMessagesMuted() { g_validation_muted.fetch_sub(1); }

// ---- Instance

Instance::Instance(bool validation, bool allow_no_driver) {
  load_vulkan();
  std::lock_guard<std::mutex> lock(g_instance_mutex);

  std::vector<const char*> layers, extensions;
  bool sync_validation = false;
  if (validation) {
    if (!has_layer(kValidationLayer))
      throw DeviceError(std::string("MESHCVT_VALIDATION asks for the Vulkan validation layer ") + kValidationLayer +
                        ", which is not installed (Debian: vulkan-validationlayers)");
    layers.push_back(kValidationLayer);
    if (!has_instance_extension(nullptr, VK_EXT_DEBUG_UTILS_EXTENSION_NAME) &&
        !has_instance_extension(kValidationLayer, VK_EXT_DEBUG_UTILS_EXTENSION_NAME))
      throw DeviceError("MESHCVT_VALIDATION needs the instance extension VK_EXT_debug_utils, which is missing");
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    sync_validation = has_instance_extension(kValidationLayer, VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
    if (sync_validation) extensions.push_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
  }

  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "meshcvt";
  app.applicationVersion = VK_MAKE_API_VERSION(0, 0, 1, 0);
  app.pEngineName = "meshcvt";
  app.engineVersion = app.applicationVersion;
  app.apiVersion = VK_API_VERSION_1_2;

  // Chained into the create info too, so messages about instance creation itself are counted.
  VkDebugUtilsMessengerCreateInfoEXT messenger_info{};
  messenger_info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
  messenger_info.messageSeverity =
      VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messenger_info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  messenger_info.pfnUserCallback = on_validation_message;

  // Synchronization validation finds missing barriers between dispatches, the bug class a compute
  // driver is most likely to have and the one that lavapipe (which runs dispatches in order) hides.
  VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
  VkValidationFeaturesEXT features{};
  features.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT;
  features.enabledValidationFeatureCount = 1;
  features.pEnabledValidationFeatures = enables;
  if (sync_validation) messenger_info.pNext = &features;

  VkInstanceCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  info.pNext = validation ? &messenger_info : nullptr;
  info.pApplicationInfo = &app;
  info.enabledLayerCount = static_cast<uint32_t>(layers.size());
  info.ppEnabledLayerNames = layers.data();
  info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();

  VkResult result = vkCreateInstance(&info, nullptr, &instance_);
  if (result == VK_ERROR_INCOMPATIBLE_DRIVER) {
    instance_ = VK_NULL_HANDLE;
    if (allow_no_driver) return;
    throw DeviceError(std::string("no Vulkan device: the Vulkan loader found no driver"), kInstallHint);
  }
  check(result, "vkCreateInstance");
  volkLoadInstanceOnly(instance_);

  if (validation) {
    messenger_info.pNext = nullptr;  // the validation features belong to the instance only
    result = vkCreateDebugUtilsMessengerEXT(instance_, &messenger_info, nullptr, &messenger_);
    if (result != VK_SUCCESS) {
      vkDestroyInstance(instance_, nullptr);
      throw_result(result, "vkCreateDebugUtilsMessengerEXT");
    }
  }
}

Instance::~Instance() {
  if (!instance_) return;
  if (messenger_) vkDestroyDebugUtilsMessengerEXT(instance_, messenger_, nullptr);
  vkDestroyInstance(instance_, nullptr);
}

std::vector<VkPhysicalDevice> Instance::physical_devices() const {
  if (!instance_) return {};
  uint32_t count = 0;
  check(vkEnumeratePhysicalDevices(instance_, &count, nullptr), "vkEnumeratePhysicalDevices");
  std::vector<VkPhysicalDevice> devices(count);
  VkResult result = vkEnumeratePhysicalDevices(instance_, &count, devices.data());
  if (result != VK_INCOMPLETE) check(result, "vkEnumeratePhysicalDevices");
  devices.resize(count);
  return devices;
}

Instance& shared_instance(bool validation) {
  static std::mutex mutex;
  static Instance* instances[2] = {nullptr, nullptr};
  std::lock_guard<std::mutex> lock(mutex);
  Instance*& instance = instances[validation ? 1 : 0];
  if (!instance) instance = new Instance(validation, /*allow_no_driver=*/true);  // never deleted, see header
  return *instance;
}

// ---- device description

DeviceInfo describe_device(VkPhysicalDevice physical, uint32_t index) {
  DeviceInfo info;
  info.index = index;
  VkPhysicalDeviceProperties properties{};
  vkGetPhysicalDeviceProperties(physical, &properties);
  info.name = properties.deviceName;
  info.type = type_name(properties.deviceType);
  info.api_version = version_string(properties.apiVersion);
  info.max_storage_buffer_range = properties.limits.maxStorageBufferRange;
  info.max_workgroup_count_x = properties.limits.maxComputeWorkGroupCount[0];

  VkPhysicalDeviceMemoryProperties memory{};
  vkGetPhysicalDeviceMemoryProperties(physical, &memory);
  for (uint32_t h = 0; h < memory.memoryHeapCount; ++h) {
    info.heap_sizes.push_back(memory.memoryHeaps[h].size);
    info.heap_device_local.push_back((memory.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) != 0);
  }

  // Extended properties: the structs may only be chained for devices of the version that has them.
  const uint32_t api = properties.apiVersion;
  bool subgroup_ballot = false;
  if (api >= VK_API_VERSION_1_1) {
    VkPhysicalDeviceSubgroupProperties subgroup{};
    subgroup.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES;
    VkPhysicalDeviceDriverProperties driver{};
    driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
    if (api >= VK_API_VERSION_1_2) subgroup.pNext = &driver;
    VkPhysicalDeviceProperties2 properties2{};
    properties2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    properties2.pNext = &subgroup;
    vkGetPhysicalDeviceProperties2(physical, &properties2);
    info.subgroup_size = subgroup.subgroupSize;
    subgroup_ballot = (subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) &&
                      (subgroup.supportedOperations & VK_SUBGROUP_FEATURE_BALLOT_BIT);
    if (api >= VK_API_VERSION_1_2) {
      info.driver_name = driver.driverName;
      info.driver_info = driver.driverInfo;
    }
  }

  std::vector<std::string> missing;
  if (api < VK_API_VERSION_1_2) {
    missing.push_back("Vulkan 1.2 (device has " + info.api_version + ")");
  } else {
    VkPhysicalDeviceVulkan12Features features12{};
    features12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
    VkPhysicalDeviceFeatures2 features{};
    features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
    features.pNext = &features12;
    vkGetPhysicalDeviceFeatures2(physical, &features);
    if (!features.features.shaderInt64) missing.push_back("shaderInt64");
    if (!features12.shaderBufferInt64Atomics) missing.push_back("shaderBufferInt64Atomics");
    if (!features12.bufferDeviceAddress) missing.push_back("bufferDeviceAddress");
    if (!subgroup_ballot) missing.push_back("subgroup ballot operations in compute shaders");
  }
  if (compute_queue_family(physical) == UINT32_MAX) missing.push_back("a compute queue");
  for (size_t i = 0; i < missing.size(); ++i) info.missing_features += (i ? ", " : "") + missing[i];
  info.usable = missing.empty();
  return info;
}

// ---- Context

Context::Context(uint32_t device_index, const ContextOptions& options)
    : instance_(shared_instance(options.validation.value_or(validation_requested()))) {
  double seconds = options.timeout_seconds ? *options.timeout_seconds : timeout_from_environment();
  if (!(seconds > 0) || !std::isfinite(seconds)) throw OptionError("GPU timeout must be a number of seconds > 0");
  timeout_ns_ = seconds >= 1e9 ? UINT64_MAX : static_cast<uint64_t>(seconds * 1e9);

  std::vector<VkPhysicalDevice> devices = instance_.physical_devices();
  if (device_index >= devices.size()) {
    std::string list;
    for (uint32_t i = 0; i < devices.size(); ++i) {
      VkPhysicalDeviceProperties p{};
      vkGetPhysicalDeviceProperties(devices[i], &p);
      list += (i ? ", " : "") + std::to_string(i) + " = " + p.deviceName;
    }
    throw DeviceError("gpu:" + std::to_string(device_index) + ": no such Vulkan device (" +
                      (devices.empty() ? std::string("there is none; ") + kInstallHint
                                       : std::to_string(devices.size()) + " found: " + list) +
                      ")");
  }
  physical_ = devices[device_index];
  info_ = describe_device(physical_, device_index);
  if (!info_.usable)
    throw DeviceError("gpu:" + std::to_string(device_index) + " " + info_.name + " cannot run meshcvt: it lacks " +
                      info_.missing_features);
  queue_family_ = compute_queue_family(physical_);
  {
    uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(physical_, &count, families.data());
    timestamp_valid_bits_ = families[queue_family_].timestampValidBits;
  }

  VkPhysicalDeviceMaintenance3Properties maintenance3{};
  maintenance3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES;
  VkPhysicalDeviceMaintenance4Properties maintenance4{};
  maintenance4.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_4_PROPERTIES;
  VkPhysicalDeviceProperties properties{};
  vkGetPhysicalDeviceProperties(physical_, &properties);
  if (properties.apiVersion >= VK_API_VERSION_1_3) maintenance3.pNext = &maintenance4;
  VkPhysicalDeviceProperties2 properties2{};
  properties2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
  properties2.pNext = &maintenance3;
  vkGetPhysicalDeviceProperties2(physical_, &properties2);
  limits_ = properties2.properties.limits;
  max_allocation_size_ = maintenance3.maxMemoryAllocationSize;
  max_buffer_size_ = maintenance4.maxBufferSize;
  vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);
  allocated_.assign(memory_.memoryHeapCount, 0);

  VkPhysicalDeviceFeatures supported{};
  vkGetPhysicalDeviceFeatures(physical_, &supported);
  has_float64_ = supported.shaderFloat64 == VK_TRUE;

  std::vector<const char*> extensions;
  has_memory_budget_ = has_device_extension(physical_, VK_EXT_MEMORY_BUDGET_EXTENSION_NAME);
  if (has_memory_budget_) extensions.push_back(VK_EXT_MEMORY_BUDGET_EXTENSION_NAME);

  VkPhysicalDeviceVulkan12Features features12{};
  features12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
  features12.bufferDeviceAddress = VK_TRUE;
  features12.shaderBufferInt64Atomics = VK_TRUE;
  VkPhysicalDeviceFeatures2 features{};
  features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  features.pNext = &features12;
  features.features.shaderInt64 = VK_TRUE;
  features.features.shaderFloat64 = supported.shaderFloat64;

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo queue_info{};
  queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  queue_info.queueFamilyIndex = queue_family_;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;

  VkDeviceCreateInfo device_info{};
  device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  device_info.pNext = &features;
  device_info.queueCreateInfoCount = 1;
  device_info.pQueueCreateInfos = &queue_info;
  device_info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  device_info.ppEnabledExtensionNames = extensions.data();
  check(vkCreateDevice(physical_, &device_info, nullptr, &device_), "vkCreateDevice");
  volkLoadDeviceTable(&table_, device_);
  table_.vkGetDeviceQueue(device_, queue_family_, 0, &queue_);
}

Context::~Context() {
  if (!device_) return;
  if (pending_ > 0) {
    // Work that timed out may still run: destroying the device under it could crash the driver.
    // The process is about to report the error and exit, so the device is leaked on purpose.
    return;
  }
  if (!failed()) table_.vkDeviceWaitIdle(device_);
  table_.vkDestroyDevice(device_, nullptr);
}

uint32_t Context::memory_type(uint32_t type_bits, MemoryUse use) const {
  const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  auto allowed = [&](uint32_t t) { return (type_bits >> t) & 1u; };
  auto flags = [&](uint32_t t) { return memory_.memoryTypes[t].propertyFlags; };
  uint32_t best = UINT32_MAX;
  int best_score = -1;
  for (uint32_t t = 0; t < memory_.memoryTypeCount; ++t) {
    if (!allowed(t)) continue;
    const VkMemoryPropertyFlags f = flags(t);
    int score = 0;
    switch (use) {
      case MemoryUse::device:
        // Device-local first; among those the type on the biggest heap, so that a discrete GPU's
        // small host-visible BAR window is not taken for big arrays.
        score = (f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) ? 2 : 1;
        break;
      case MemoryUse::staging:
        if ((f & host) != host) continue;
        score = (f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) ? 1 : 2;  // system memory is meant for this
        break;
      case MemoryUse::readback:
        if ((f & host) != host) continue;
        score = (f & VK_MEMORY_PROPERTY_HOST_CACHED_BIT) ? 2 : 1;  // host reads of uncached memory crawl
        break;
    }
    if (score > best_score ||
        (score == best_score && use == MemoryUse::device &&
         memory_.memoryHeaps[memory_.memoryTypes[t].heapIndex].size >
             memory_.memoryHeaps[memory_.memoryTypes[best].heapIndex].size)) {
      best = t;
      best_score = score;
    }
  }
  if (best == UINT32_MAX)
    throw DeviceError("the Vulkan device " + info_.name + " has no " +
                      (use == MemoryUse::device ? "memory type" : "host-visible coherent memory type") +
                      " for a buffer");
  return best;
}

uint64_t Context::heap_available(uint32_t heap) const {
  assert(heap < memory_.memoryHeapCount);
  if (has_memory_budget_) {
    VkPhysicalDeviceMemoryBudgetPropertiesEXT budget{};
    budget.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_BUDGET_PROPERTIES_EXT;
    VkPhysicalDeviceMemoryProperties2 properties{};
    properties.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_PROPERTIES_2;
    properties.pNext = &budget;
    vkGetPhysicalDeviceMemoryProperties2(physical_, &properties);
    return budget.heapBudget[heap] > budget.heapUsage[heap] ? budget.heapBudget[heap] - budget.heapUsage[heap] : 0;
  }
  const uint64_t size = memory_.memoryHeaps[heap].size;
  return size > allocated_[heap] ? size - allocated_[heap] : 0;
}

void Context::check_allocation(uint64_t bytes, uint32_t heap, const std::string& what) const {
  ensure_usable();
  const uint64_t available = heap_available(heap);
  const std::string prefix = "cannot allocate " + what + " on " + info_.name + ": " + mib(bytes) + " requested, ";
  if (bytes > available)
    throw DeviceError(prefix + mib(available) + " available in memory heap " + std::to_string(heap) + " (" +
                      mib(memory_.memoryHeaps[heap].size) + " in all" +
                      (has_memory_budget_ ? ", per VK_EXT_memory_budget)" : ")"),
                      "try a smaller mesh or --device cpu");
  if (max_allocation_size_ && bytes > max_allocation_size_)
    throw DeviceError(prefix + "but one allocation may hold at most " + mib(max_allocation_size_) +
                      " (maxMemoryAllocationSize)");
  if (max_buffer_size_ && bytes > max_buffer_size_)
    throw DeviceError(prefix + "but one buffer may hold at most " + mib(max_buffer_size_) + " (maxBufferSize)");
}

void Context::fail(const std::string& reason) {
  if (failure_.empty()) failure_ = reason;
}

void Context::ensure_usable() const {
  if (failed()) throw DeviceError("the Vulkan device " + info_.name + " is unusable after an earlier error: " + failure_);
}

void arm_faults_from_environment(Context& context) {
  const char* text = std::getenv("MESHCVT_GPU_FAULT");
  if (!text || !*text) {
    context.arm_fault(Context::Fault::none, 0);
    return;
  }
  const std::string value = text;
  const size_t colon = value.find(':');
  const std::string kind = value.substr(0, colon), count = colon == std::string::npos ? "" : value.substr(colon + 1);
  const bool digits = !count.empty() && count.size() <= 9 && count.find_first_not_of("0123456789") == std::string::npos;
  const uint32_t n = digits ? uint32_t(std::stoul(count)) : 0;
  if ((kind != "lost" && kind != "memory") || n == 0)
    throw OptionError("MESHCVT_GPU_FAULT=" + value + ": expected lost:N or memory:N with N >= 1");
  context.arm_fault(kind == "lost" ? Context::Fault::device_lost : Context::Fault::out_of_memory, n);
}

std::string mib(uint64_t bytes) {
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "%.1f MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
  return buffer;
}

}  // namespace meshcvt::vk

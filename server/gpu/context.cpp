#include "gpu/context.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "gpu/pipelines.h"
#include "gpu/vk_check.h"

namespace myriad::gpu {

VulkanError::VulkanError(VkResult r, const char* expression, const char* file, int line)
    : std::runtime_error(std::string(expression) + " failed with " + resultName(r) + " at " + file +
                         ":" + std::to_string(line)),
      result(r) {}

const char* resultName(VkResult result) {
  switch (result) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_INCOMPLETE: return "VK_INCOMPLETE";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED: return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_TOO_MANY_OBJECTS: return "VK_ERROR_TOO_MANY_OBJECTS";
    case VK_ERROR_FORMAT_NOT_SUPPORTED: return "VK_ERROR_FORMAT_NOT_SUPPORTED";
    case VK_ERROR_OUT_OF_POOL_MEMORY: return "VK_ERROR_OUT_OF_POOL_MEMORY";
    default: return "VkResult(other)";
  }
}

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
constexpr const char* kNoDeviceHelp =
    "install a Vulkan driver: on Debian/Ubuntu `apt-get install mesa-vulkan-drivers` gives "
    "lavapipe (Vulkan on the CPU), or install your GPU vendor's driver, or run Myriad's container "
    "(docker/Dockerfile)";

VKAPI_ATTR VkBool32 VKAPI_CALL onValidationMessage(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT type,
    const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  // Performance hints are advice, not errors: tests fail on validation and spec messages only.
  if (type == VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT) return VK_FALSE;
  auto* context = static_cast<Context*>(user);
  context->validationMessages.fetch_add(1, std::memory_order_relaxed);
  const char* level =
      (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) ? "error" : "warning";
  std::fprintf(stderr, "[vulkan-validation] %s: %s\n", level, data->pMessage);
  std::fflush(stderr);
  return VK_FALSE;
}

bool layerAvailable(const char* name) {
  uint32_t count = 0;
  vkEnumerateInstanceLayerProperties(&count, nullptr);
  std::vector<VkLayerProperties> layers(count);
  vkEnumerateInstanceLayerProperties(&count, layers.data());
  return std::any_of(layers.begin(), layers.end(),
                     [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

std::string versionString(uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) +
         "." + std::to_string(VK_API_VERSION_PATCH(v));
}

const char* typeName(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete-gpu";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated-gpu";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual-gpu";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

int typeRank(const std::string& type) {
  if (type == "discrete-gpu") return 0;
  if (type == "integrated-gpu") return 1;
  if (type == "virtual-gpu") return 2;
  if (type == "other") return 3;
  return 4;  // cpu
}

// The first queue family that does graphics and compute (timestamps checked separately).
int findQueueFamily(VkPhysicalDevice physical) {
  uint32_t count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, nullptr);
  std::vector<VkQueueFamilyProperties> families(count);
  vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, families.data());
  for (uint32_t i = 0; i < count; ++i) {
    const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
    if ((families[i].queueFlags & need) == need) return static_cast<int>(i);
  }
  return -1;
}

bool deviceExtensionAvailable(VkPhysicalDevice physical, const char* name) {
  uint32_t count = 0;
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr);
  std::vector<VkExtensionProperties> extensions(count);
  vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, extensions.data());
  return std::any_of(extensions.begin(), extensions.end(),
                     [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

DeviceInfo describe(VkPhysicalDevice physical, uint32_t index) {
  VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
  VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  subgroup.pNext = &driver;
  // The multiprocessor count, where an extension the device has tells it (properties of a
  // supported extension may be queried without enabling it).
  VkPhysicalDeviceShaderSMBuiltinsPropertiesNV nvidia{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_SM_BUILTINS_PROPERTIES_NV};
  VkPhysicalDeviceShaderCorePropertiesAMD amd{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_CORE_PROPERTIES_AMD};
  const bool hasNvidia = deviceExtensionAvailable(physical, VK_NV_SHADER_SM_BUILTINS_EXTENSION_NAME);
  const bool hasAmd = deviceExtensionAvailable(physical, VK_AMD_SHADER_CORE_PROPERTIES_EXTENSION_NAME);
  if (hasNvidia) {
    nvidia.pNext = subgroup.pNext;
    subgroup.pNext = &nvidia;
  }
  if (hasAmd) {
    amd.pNext = subgroup.pNext;
    subgroup.pNext = &amd;
  }
  VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  props.pNext = &subgroup;
  vkGetPhysicalDeviceProperties2(physical, &props);
  const VkPhysicalDeviceProperties& p = props.properties;

  DeviceInfo info;
  info.name = p.deviceName;
  info.type = typeName(p.deviceType);
  info.driverName = driver.driverName;
  info.driverInfo = driver.driverInfo;
  info.apiVersion = versionString(p.apiVersion);
  info.vendorId = p.vendorID;
  info.deviceId = p.deviceID;
  info.index = index;
  info.isCpu = p.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  info.maxImageDimension2D = p.limits.maxImageDimension2D;
  info.maxStorageBufferRange = p.limits.maxStorageBufferRange;
  info.maxTexelBufferElements = p.limits.maxTexelBufferElements;
  info.maxComputeSharedMemorySize = p.limits.maxComputeSharedMemorySize;
  info.maxComputeWorkGroupInvocations = p.limits.maxComputeWorkGroupInvocations;
  info.maxComputeWorkGroupSizeX = p.limits.maxComputeWorkGroupSize[0];
  info.subgroupSize = subgroup.subgroupSize;
  const VkSubgroupFeatureFlags shuffle = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_VOTE_BIT |
                                         VK_SUBGROUP_FEATURE_ARITHMETIC_BIT |
                                         VK_SUBGROUP_FEATURE_BALLOT_BIT | VK_SUBGROUP_FEATURE_SHUFFLE_BIT;
  info.computeSubgroupShuffle = (subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) != 0 &&
                                (subgroup.supportedOperations & shuffle) == shuffle;
  if (hasNvidia) {
    info.multiprocessors = nvidia.shaderSMCount;
  } else if (hasAmd) {
    info.multiprocessors =
        amd.shaderEngineCount * amd.shaderArraysPerEngineCount * amd.computeUnitsPerShaderArray;
  }
  info.timestampPeriodNs = p.limits.timestampPeriod;
  int family = findQueueFamily(physical);
  if (family >= 0) {
    uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, families.data());
    info.timestampsSupported = families[family].timestampValidBits > 0 && p.limits.timestampPeriod > 0;
  }
  return info;
}

VkInstance createInstance(bool validation, uint32_t* apiVersionOut) {
  uint32_t loaderVersion = VK_API_VERSION_1_0;
  if (vkEnumerateInstanceVersion(&loaderVersion) != VK_SUCCESS ||
      loaderVersion < VK_API_VERSION_1_3) {
    throw NoDeviceError("The Vulkan loader supports only Vulkan " + versionString(loaderVersion) +
                        "; Myriad needs 1.3: " + kNoDeviceHelp + ".");
  }
  *apiVersionOut = VK_API_VERSION_1_3;
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "myriad-server";
  app.pEngineName = "Myriad";
  app.apiVersion = VK_API_VERSION_1_3;

  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  if (validation) {
    if (!layerAvailable(kValidationLayer)) {
      throw NoDeviceError(
          "Validation was requested but VK_LAYER_KHRONOS_validation is not installed: "
          "apt-get install vulkan-validationlayers.");
    }
    layers.push_back(kValidationLayer);
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    extensions.push_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);  // provided by the layer
  }
  // Core validation checks API usage, not whether barriers order the work: a compute pass reading
  // an image whose barrier only waited for fragment shaders passes core validation and races on
  // a real GPU. Synchronization validation catches exactly that, so it is on whenever
  // validation is.
  const VkValidationFeatureEnableEXT enabledChecks[] = {
      VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
  VkValidationFeaturesEXT validationFeatures{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  validationFeatures.enabledValidationFeatureCount = 1;
  validationFeatures.pEnabledValidationFeatures = enabledChecks;
  VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  info.pNext = validation ? &validationFeatures : nullptr;
  info.pApplicationInfo = &app;
  info.enabledLayerCount = static_cast<uint32_t>(layers.size());
  info.ppEnabledLayerNames = layers.data();
  info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();
  VkInstance instance = VK_NULL_HANDLE;
  VkResult result = vkCreateInstance(&info, nullptr, &instance);
  if (result == VK_ERROR_INCOMPATIBLE_DRIVER || result == VK_ERROR_INITIALIZATION_FAILED) {
    throw NoDeviceError(std::string("No Vulkan driver could be loaded (") + resultName(result) +
                        "): " + kNoDeviceHelp + ".");
  }
  VK_CHECK(result);
  return instance;
}

std::vector<VkPhysicalDevice> usablePhysicalDevices(VkInstance instance) {
  uint32_t count = 0;
  VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, nullptr));
  std::vector<VkPhysicalDevice> all(count);
  VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, all.data()));
  std::vector<VkPhysicalDevice> usable;
  for (VkPhysicalDevice physical : all) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(physical, &p);
    if (p.apiVersion >= VK_API_VERSION_1_3 && findQueueFamily(physical) >= 0) {
      usable.push_back(physical);
    }
  }
  return usable;
}

}  // namespace

int chooseDevice(const std::vector<DeviceInfo>& devices, const std::string& selector) {
  if (devices.empty()) return -1;
  if (!selector.empty()) {
    bool numeric = std::all_of(selector.begin(), selector.end(), [](char c) { return c >= '0' && c <= '9'; });
    if (numeric && selector.size() < 9) {
      size_t index = std::stoul(selector);
      return index < devices.size() ? static_cast<int>(index) : -1;
    }
    auto lower = [](std::string s) {
      std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
      return s;
    };
    for (size_t i = 0; i < devices.size(); ++i) {
      if (lower(devices[i].name).find(lower(selector)) != std::string::npos) return static_cast<int>(i);
    }
    return -1;
  }
  int best = 0;
  for (size_t i = 1; i < devices.size(); ++i) {
    if (typeRank(devices[i].type) < typeRank(devices[best].type)) best = static_cast<int>(i);
  }
  return best;
}

std::vector<DeviceInfo> listDevices() {
  uint32_t apiVersion = 0;
  VkInstance instance = createInstance(false, &apiVersion);
  std::vector<DeviceInfo> infos;
  auto physicals = usablePhysicalDevices(instance);
  for (uint32_t i = 0; i < physicals.size(); ++i) infos.push_back(describe(physicals[i], i));
  vkDestroyInstance(instance, nullptr);
  return infos;
}

std::unique_ptr<Context> createContext(const ContextOptions& options) {
  auto context = std::make_unique<Context>();
  uint32_t apiVersion = 0;
  context->instance = createInstance(options.validation, &apiVersion);

  if (options.validation) {
    VkDebugUtilsMessengerCreateInfoEXT info{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    info.pfnUserCallback = onValidationMessage;
    info.pUserData = context.get();
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(context->instance, "vkCreateDebugUtilsMessengerEXT"));
    VK_CHECK(create(context->instance, &info, nullptr, &context->messenger));
  }

  auto physicals = usablePhysicalDevices(context->instance);
  std::vector<DeviceInfo> infos;
  for (uint32_t i = 0; i < physicals.size(); ++i) infos.push_back(describe(physicals[i], i));
  if (infos.empty()) {
    throw NoDeviceError(std::string("No Vulkan 1.3 device with a graphics+compute queue was found: ") +
                        kNoDeviceHelp + ".");
  }
  int chosen = chooseDevice(infos, options.device);
  if (chosen < 0) {
    std::string names;
    for (const auto& d : infos) names += (names.empty() ? "" : ", ") + std::to_string(d.index) + ": " + d.name;
    throw NoDeviceError("--device " + options.device + " matches no Vulkan 1.3 device (found " + names + ").");
  }
  context->physicalDevice = physicals[chosen];
  context->info = infos[chosen];
  context->queueFamily = static_cast<uint32_t>(findQueueFamily(context->physicalDevice));
  vkGetPhysicalDeviceMemoryProperties(context->physicalDevice, &context->memoryProperties);

  VkPhysicalDeviceFeatures supported{};
  vkGetPhysicalDeviceFeatures(context->physicalDevice, &supported);
  context->depthClamp = supported.depthClamp == VK_TRUE;
  context->fragmentStores = supported.fragmentStoresAndAtomics == VK_TRUE;
  if (supported.samplerAnisotropy == VK_TRUE) {
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(context->physicalDevice, &properties);
    context->maxAnisotropy = properties.limits.maxSamplerAnisotropy;
  }

  VkPhysicalDeviceVulkan13Features supported13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  VkPhysicalDeviceVulkan12Features supported12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  supported13.pNext = &supported12;
  VkPhysicalDeviceFeatures2 query{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  query.pNext = &supported13;
  vkGetPhysicalDeviceFeatures2(context->physicalDevice, &query);
  // Shaders are SPIR-V 1.6 (--target-env vulkan1.3), whose compute shaders declare their workgroup
  // size with LocalSizeId: that needs maintenance4.
  if (!supported13.dynamicRendering || !supported13.synchronization2 || !supported13.maintenance4) {
    throw NoDeviceError(context->info.name +
                        " lacks a Vulkan 1.3 feature Myriad needs (dynamicRendering, "
                        "synchronization2, maintenance4): update its driver, or choose another "
                        "device with --device.");
  }
  VkPhysicalDeviceVulkan13Features features13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  features13.dynamicRendering = VK_TRUE;
  features13.synchronization2 = VK_TRUE;
  features13.maintenance4 = VK_TRUE;
  context->int64Atomics = supported.shaderInt64 == VK_TRUE &&
                          supported12.shaderBufferInt64Atomics == VK_TRUE;
  VkPhysicalDeviceVulkan12Features features12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  features12.shaderBufferInt64Atomics = context->int64Atomics ? VK_TRUE : VK_FALSE;
  features13.pNext = &features12;
  VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  features.pNext = &features13;
  features.features.shaderInt64 = context->int64Atomics ? VK_TRUE : VK_FALSE;
  features.features.depthClamp = supported.depthClamp;
  features.features.samplerAnisotropy = supported.samplerAnisotropy;
  features.features.fragmentStoresAndAtomics = supported.fragmentStoresAndAtomics;

  // A diagnostic: options.pipelineStatistics has compute pipelines print the driver's statistics
  // (gpu/pipelines.h, capturePipelineStatistics) where the device can say them.
  std::vector<const char*> deviceExtensions;
  VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR executableInfo{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR};
  if (options.pipelineStatistics &&
      deviceExtensionAvailable(context->physicalDevice,
                         VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME)) {
    deviceExtensions.push_back(VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
    executableInfo.pipelineExecutableInfo = VK_TRUE;
    executableInfo.pNext = features.pNext;
    features.pNext = &executableInfo;
    capturePipelineStatistics(true);
  }

  float priority = 1.0f;
  VkDeviceQueueCreateInfo queueInfo{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  queueInfo.queueFamilyIndex = context->queueFamily;
  queueInfo.queueCount = 1;
  queueInfo.pQueuePriorities = &priority;
  VkDeviceCreateInfo deviceInfo{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  deviceInfo.pNext = &features;
  deviceInfo.queueCreateInfoCount = 1;
  deviceInfo.pQueueCreateInfos = &queueInfo;
  deviceInfo.enabledExtensionCount = static_cast<uint32_t>(deviceExtensions.size());
  deviceInfo.ppEnabledExtensionNames = deviceExtensions.data();
  VK_CHECK(vkCreateDevice(context->physicalDevice, &deviceInfo, nullptr, &context->device));
  vkGetDeviceQueue(context->device, context->queueFamily, 0, &context->queue);
  return context;
}

Context::~Context() {
  if (device) {
    vkDeviceWaitIdle(device);
    vkDestroyDevice(device, nullptr);
  }
  if (messenger) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
    destroy(instance, messenger, nullptr);
  }
  if (instance) vkDestroyInstance(instance, nullptr);
}

}  // namespace myriad::gpu

// The scene as plain CPU data: what the renderer draws and the service edits. Knows nothing of
// Vulkan or HTTP.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace myriad::scene {

struct Vertex {
  glm::vec3 position{0.0f};
  glm::vec3 normal{0.0f, 1.0f, 0.0f};
  glm::vec2 uv{0.0f};
  // xyz the tangent (along +u), w the bitangent's sign (bitangent = w * cross(normal, tangent)),
  // as glTF's TANGENT: the file's, or MikkTSpace's for a normal-mapped glTF primitive without
  // them (scene/tangents.h). w = 0: none (no normal map, or no usable uvs); the G-buffer pass
  // then derives a tangent frame per pixel from screen-space derivatives of position and uv.
  glm::vec4 tangent{0.0f};
  glm::vec4 color{1.0f};  // COLOR_0, linear RGBA (white where the file has none)
};

// A coarser version of a mesh's surface over the same vertices: fewer triangles for a frame that
// may trade geometry it cannot show for speed (a stream's interactive frames, FrameSettings::
// geometryErrorPixels). `error` bounds the distance between its surface and the mesh's, in the
// mesh's units.
struct MeshLod {
  std::vector<uint32_t> indices;  // triangle list into Mesh::vertices, as Mesh::indices
  float error = 0.0f;
};

// One glTF morph target of a mesh: per-vertex displacements added, times the target's weight, to
// the mesh's rest vertices. Each list is empty (the target does not move that attribute) or holds
// one entry per vertex of the mesh.
struct MorphTarget {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;
  std::vector<glm::vec3> tangents;  // xyz of the tangent; the sign (w) is not morphed
};

struct Mesh {
  std::string name;
  std::vector<Vertex> vertices;
  std::vector<uint32_t> indices;  // triangle list, counter-clockwise front faces
  // Skinning (glTF JOINTS_0 / WEIGHTS_0): per vertex up to four joints, as indices into the
  // Skin::joints of the skin its instance uses, and their weights (summing to 1). Both empty
  // for a mesh that is not skinned, else one entry per vertex.
  std::vector<glm::uvec4> joints;
  std::vector<glm::vec4> weights;
  // Morph targets (glTF mesh.primitives[].targets) and the mesh's default weights (mesh.weights,
  // one per target; zeros where the file gives none).
  std::vector<MorphTarget> morphTargets;
  std::vector<float> morphWeights;
  bool skinned() const { return !joints.empty(); }
  bool morphed() const { return !morphTargets.empty(); }
  // Coarser versions, finest first (empty for most meshes: the procedural sphere has them).
  std::vector<MeshLod> lods;
};

// Which version of a mesh to draw where one mesh unit covers `pixelsPerUnit` pixels on screen,
// given its LODs' errors (finest first, as Mesh::lods): the index of the coarsest whose error
// covers at most `maxErrorPixels`, or -1 for the mesh itself (also when maxErrorPixels <= 0).
int coarsestLodWithin(std::span<const float> lodErrors, float pixelsPerUnit, float maxErrorPixels);

// A decoded texture image: RGBA8, rows top first, as the file stored it (base colour and emissive
// images are sRGB-encoded, the data maps linear; the renderer views each as its use needs).
struct Image {
  std::string name;
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> rgba;  // width * height * 4 bytes
};

// How a texture is sampled (glTF samplers; formats that do not say get the defaults).
struct Sampler {
  enum class Wrap : uint8_t { repeat, clampToEdge, mirroredRepeat };
  enum class Filter : uint8_t { linear, nearest };
  Wrap wrapS = Wrap::repeat;
  Wrap wrapT = Wrap::repeat;
  Filter magFilter = Filter::linear;
  Filter minFilter = Filter::linear;
  bool mipmaps = true;                  // the minification filter reads the mip chain
  Filter mipmapFilter = Filter::linear;  // between mip levels

  bool operator==(const Sampler&) const = default;
};

// A material's use of an image. KHR_texture_transform: uv' = T(offset) R(rotation) S(scale) uv.
struct TextureRef {
  static constexpr uint32_t kNone = UINT32_MAX;
  uint32_t image = kNone;  // index into Scene::images
  Sampler sampler;
  glm::vec2 offset{0.0f};
  glm::vec2 scale{1.0f};
  float rotation = 0.0f;  // radians, counter-clockwise in uv space
  uint32_t texCoord = 0;  // only set 0 is carried

  bool present() const { return image != kNone; }
};

enum class AlphaMode : uint8_t { opaque, mask, blend };

// The glTF 2.0 metallic-roughness material. Colours are linear RGB.
struct Material {
  std::string name;
  glm::vec3 baseColor{0.8f};
  float metallic = 0.0f;
  float roughness = 0.5f;
  float alpha = 1.0f;               // base colour alpha factor
  glm::vec3 emissive{0.0f};         // emissiveFactor
  float emissiveStrength = 1.0f;    // KHR_materials_emissive_strength
  float normalScale = 1.0f;         // normalTexture.scale
  float occlusionStrength = 1.0f;   // occlusionTexture.strength
  AlphaMode alphaMode = AlphaMode::opaque;
  float alphaCutoff = 0.5f;         // MASK: fragments with alpha below it are not drawn
  bool doubleSided = true;          // false: back faces culled (formats that do not say: true)
  bool unlit = false;               // KHR_materials_unlit: base colour is the output, unlit
  float ior = 1.5f;                 // KHR_materials_ior: the dielectric's F0, ((ior-1)/(ior+1))^2
  float specular = 1.0f;            // KHR_materials_specular's specularFactor: scales the
                                    // dielectric's reflection (F0 and F90)
  float clearcoat = 0.0f;           // KHR_materials_clearcoat's clearcoatFactor (0: no coat)
  float clearcoatRoughness = 0.0f;  // and its clearcoatRoughnessFactor (perceptual)
  glm::vec3 sheenColor{0.0f};       // KHR_materials_sheen's sheenColorFactor (0: no sheen)
  float sheenRoughness = 0.0f;      // and its sheenRoughnessFactor
  // Whether the material has a clear coat or a sheen: what the layers G-buffer target is for.
  bool layered() const { return clearcoat > 0.0f || sheenColor != glm::vec3(0.0f); }
  TextureRef baseColorTexture;          // sRGB, RGBA: colour and alpha
  TextureRef metallicRoughnessTexture;  // linear: B metallic, G roughness
  TextureRef normalTexture;             // linear: tangent-space normal
  TextureRef occlusionTexture;          // linear: R occlusion
  TextureRef emissiveTexture;           // sRGB

  // The five references in a fixed order (the order of the GPU descriptor bindings).
  static constexpr size_t kTextureSlots = 5;
  const TextureRef& texture(size_t slot) const {
    const TextureRef* refs[] = {&baseColorTexture, &metallicRoughnessTexture, &normalTexture,
                                &occlusionTexture, &emissiveTexture};
    return *refs[slot];
  }
  TextureRef& texture(size_t slot) {
    return const_cast<TextureRef&>(static_cast<const Material&>(*this).texture(slot));
  }
};


// One placement of a mesh in the world.
struct Instance {
  uint32_t mesh = 0;
  uint32_t material = 0;
  glm::mat4 transform{1.0f};
  // The session object this instance belongs to (the instance-id label; 0: none, e.g. a scene
  // made without objects).
  uint32_t object = 0;
  uint32_t semantic = 0;  // its object's semantic class (the semantic-id label)
  // The model node it hangs from (index into Scene::nodes; -1: none, its transform is fixed).
  // An animated node's instances move with it (scene/animation.h).
  int32_t node = -1;
  // The skin deforming its mesh (index into Scene::skins; -1: none). A skinned instance's
  // vertices are placed by its joints, not by its node (glTF 2.0 skins): `transform` then only
  // places the asset (the object's world transform).
  int32_t skin = -1;
};

// A model file's node (glTF 2.0 nodes), kept so animation can move it. Its local transform is
// translation * rotation * scale (a node given as a matrix is decomposed on load).
struct Node {
  std::string name;
  int32_t parent = -1;  // index into Scene::nodes, always lower than this node's (parents first)
  glm::vec3 translation{0.0f};
  glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};  // unit (glm: w, x, y, z)
  glm::vec3 scale{1.0f};
};

// A glTF skin: the nodes acting as its joints and their inverse bind matrices (one each).
struct Skin {
  std::string name;
  std::vector<uint32_t> joints;  // indices into Scene::nodes
  std::vector<glm::mat4> inverseBind;
};

// A glTF animation: channels, each a sampler driving one property of one node.
enum class AnimationPath : uint8_t { translation, rotation, scale, weights };
enum class Interpolation : uint8_t { step, linear, cubicSpline };
struct AnimationChannel {
  uint32_t node = 0;  // index into Scene::nodes (weights: the morph weights of its meshes)
  AnimationPath path = AnimationPath::translation;
  Interpolation interpolation = Interpolation::linear;
  std::vector<float> times;  // seconds, strictly increasing
  // Per key: 3 floats (translation, scale), 4 (rotation, x y z w as glTF) or one per morph target
  // (weights); cubic spline keys hold in-tangent, value, out-tangent, in that order.
  std::vector<float> values;
};
struct Animation {
  std::string name;
  float duration = 0.0f;  // the last key time over its channels
  std::vector<AnimationChannel> channels;
};

// How a local light's radiance falls off with distance d; both are exactly zero at and beyond the
// light's radius (shaders/shading.glsl, distanceAttenuation and inverseSquareAttenuation).
enum class Attenuation : uint8_t {
  Window,         // clamp((r^2 - d^2) / (C*d^2 + r^2), 0, 1): 1 at the light (the seed's falloff)
  InverseSquare,  // 1 / max(d^2, kMinLightDistance^2) * clamp(1 - (d/r)^4, 0, 1)^2 (glTF's)
};

enum class LightType : uint8_t {
  Point,  // every direction
  Spot,   // a cone around `direction` (glTF KHR_lights_punctual's spot)
};

// The largest float not above pi/2 (float(pi/2) is just above it): a spot's widest outer cone.
inline constexpr float kMaxConeAngle = 1.570796251296997f;

// A local light: radiance = color * intensity * attenuation(d) * cone(angle). The cone term is 1
// for a point light; for a spot it is glTF's smooth falloff from 1 inside innerConeAngle to 0 at
// and beyond outerConeAngle (both from `direction`, radians, 0 <= inner < outer <= pi/2).
// Zero at and beyond `radius`.
struct PointLight {
  glm::vec3 position{0.0f};
  float radius = 1.0f;
  glm::vec3 color{1.0f};
  float intensity = 1.0f;
  float falloff = 1.0f;  // the attenuation constant C (>= 0) of Attenuation::Window
  LightType type = LightType::Point;
  Attenuation attenuation = Attenuation::Window;
  glm::vec3 direction{0.0f, -1.0f, 0.0f};  // unit; the way a spot light points
  float innerConeAngle = 0.0f;             // glTF's defaults
  float outerConeAngle = 0.78539816339744831f;
  // The light asks for a shadow map (render/shadows.h): it gets one when it is among the frame's
  // most important asking lights, up to settings.shadows.maxShadowedLights; else it is unshadowed.
  bool castsShadows = false;
};

struct Sun {
  glm::vec3 direction = glm::normalize(glm::vec3(-0.4f, -1.0f, -0.3f));  // the way light travels
  glm::vec3 color{1.0f, 0.96f, 0.9f};
  float intensity = 2.0f;
};

// Directional lights besides the sun: a model file's (glTF KHR_lights_punctual "directional"), at
// most this many (the brightest; the rest are counted in Scene::droppedSuns). With the sun, four.
inline constexpr size_t kMaxExtraSuns = 3;

// A camera a model file defines (glTF 2.0 cameras), placed by its node: it looks along the node's
// -Z with the node's +Y up.
struct ModelCamera {
  std::string name;
  bool perspective = true;  // false: orthographic (listed, not usable as the session's camera)
  float yfov = 0.8f;        // radians (perspective)
  float aspectRatio = 0.0f; // 0 when the file gives none
  float znear = 0.01f;
  float zfar = 0.0f;        // 0 when the file gives none (infinite)
  glm::vec3 position{0.0f};
  glm::vec3 direction{0.0f, 0.0f, -1.0f};  // unit
  glm::vec3 up{0.0f, 1.0f, 0.0f};          // unit, perpendicular to direction
};

struct Bounds {
  glm::vec3 min{std::numeric_limits<float>::max()};
  glm::vec3 max{std::numeric_limits<float>::lowest()};

  bool empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
  void extend(const glm::vec3& p) {
    min = glm::min(min, p);
    max = glm::max(max, p);
  }
  glm::vec3 center() const { return 0.5f * (min + max); }
  glm::vec3 size() const { return max - min; }
};

struct Camera {
  glm::vec3 eye{0.0f, 2.0f, 6.0f};
  glm::vec3 target{0.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  float fovYDegrees = 50.0f;
  float nearPlane = 0.05f;
  float farPlane = 200.0f;
};

struct Scene {
  std::vector<Mesh> meshes;
  std::vector<Material> materials;
  std::vector<Instance> instances;
  std::vector<Image> images;  // what the materials' TextureRefs index
  std::vector<PointLight> lights;
  Sun sun;
  std::vector<Sun> extraSuns;  // at most kMaxExtraSuns more directional lights (a model's)
  uint32_t droppedSuns = 0;    // the model's directional lights past kMaxExtraSuns, not used
  std::vector<ModelCamera> cameras;  // the model file's cameras, in the file's order
  // The glTF extensions the file uses that Myriad does not honour (sorted; the model summary
  // lists them): what the picture may lack.
  std::vector<std::string> ignoredExtensions;
  // The file's node tree, skins and animations (empty for formats and files without them).
  std::vector<Node> nodes;
  std::vector<Skin> skins;
  std::vector<Animation> animations;
  glm::vec3 ambient{0.03f, 0.035f, 0.045f};
  glm::vec3 background{0.02f, 0.025f, 0.035f};
  Camera camera;  // the default view (frames the scene)

  // World-space bounds of every instance's transformed vertices.
  Bounds bounds() const;
};

// The bounds of `mesh`'s vertices moved by `transform`: what Scene::bounds() unites over the
// instances (exact, not a transformed box), so that bounds kept per instance and united again
// equal Scene::bounds() bit for bit.
Bounds transformedBounds(const Mesh& mesh, const glm::mat4& transform);

}  // namespace myriad::scene

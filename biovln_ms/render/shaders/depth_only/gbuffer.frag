#version 450
// BioVLN-MS depth-only camera pass: view-space position (millimetres) and segmentation ids. A fully
// transparent texel is still discarded, as in the lit passes, so the same surfaces are seen.

// SAPIEN tells a descriptor set's role by its binding 0, so each set used declares it
layout(set = 1, binding = 0) uniform ObjectTransformBuffer {
  mat4 modelMatrix;
} objectTransformBuffer;

layout(set = 1, binding = 1) uniform ObjectDataBuffer {
  uvec4 segmentation;
  float transparency;
  int shadeFlat;
} objectDataBuffer;

layout(set = 2, binding = 0) uniform MaterialBuffer {
  vec4 emission;
  vec4 baseColor;
  float fresnel;
  float roughness;
  float metallic;
  float transmission;
  float ior;
  float transmissionRoughness;
  int textureMask;
  int padding1;
  vec4 textureTransforms[6];
} materialBuffer;

layout(set = 2, binding = 1) uniform sampler2D colorTexture;

// the scene's lights (set 3): declared because SAPIEN binds them to every camera pass; unused here
struct PointLight { vec4 position; vec4 emission; };
struct DirectionalLight { vec4 direction; vec4 emission; };
struct SpotLight { vec4 position; vec4 direction; vec4 emission; };

layout(set = 3, binding = 0) uniform SceneBuffer {
  vec4 ambientLight;
  PointLight pointLights[10];
  DirectionalLight directionalLights[3];
  SpotLight spotLights[10];
  SpotLight texturedLights[1];
} sceneBuffer;

layout(location = 0) in vec4 viewPosition;
layout(location = 1) in vec2 texCoord;
layout(location = 2) in flat uvec4 segmentation;

layout(location = 0) out ivec4 outPositionSegmentation;

void main() {
  float alpha = materialBuffer.baseColor.a;
  if ((materialBuffer.textureMask & 1) != 0) {
    vec4 t = materialBuffer.textureTransforms[0];
    alpha = texture(colorTexture, texCoord * t.zw + t.xy).a;
  }
  if (alpha * (1.f - objectDataBuffer.transparency) == 0) {
    discard;
  }
  outPositionSegmentation = ivec4(ivec3(viewPosition * 1000), segmentation[1]);
}

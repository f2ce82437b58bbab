#version 450
// BioVLN-MS depth-only camera pass: where each surface point lies, nothing about its colour.
// The position arithmetic is the one SAPIEN's camera passes use (view * model, then the
// projection), so depth and segmentation match theirs bit for bit.

layout(set = 0, binding = 0) uniform CameraBuffer {
  mat4 viewMatrix;
  mat4 projectionMatrix;
  mat4 viewMatrixInverse;
  mat4 projectionMatrixInverse;
  float width;
  float height;
} cameraBuffer;

layout(set = 1, binding = 0) uniform ObjectTransformBuffer {
  mat4 modelMatrix;
} objectTransformBuffer;

layout(set = 1, binding = 1) uniform ObjectDataBuffer {
  uvec4 segmentation;
  float transparency;
  int shadeFlat;
} objectDataBuffer;

// the vertex layout every camera pass of a scene shares (SAPIEN requires it); only position and uv are used
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec2 uv;
layout(location = 3) in vec3 tangent;
layout(location = 4) in vec3 bitangent;

layout(location = 0) out vec4 viewPosition;
layout(location = 1) out vec2 texCoord;
layout(location = 2) out flat uvec4 segmentation;

void main() {
  mat4 modelView = cameraBuffer.viewMatrix * objectTransformBuffer.modelMatrix;
  viewPosition = modelView * vec4(position, 1);
  texCoord = uv;
  segmentation = objectDataBuffer.segmentation;
  gl_Position = cameraBuffer.projectionMatrix * viewPosition;
}

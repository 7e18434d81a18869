// Binary glTF 2.0 (.glb) through tinygltf: one mesh, material and node per tile, textures embedded
// as PNG in the single binary buffer, unlit materials (the texture already carries the light).
// glTF is y-up: world (x, y, z) → glTF (x, z, −y), relative to the centre of the mesh, which is
// put back as the root node's translation so the file keeps world coordinates.
#include <tiny_gltf.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "terramrf/atomic_file.hpp"
#include "terramrf/meshing/mesh_export.hpp"
#include "terramrf/text_format.hpp"

namespace terramrf::meshing {

namespace {

std::vector<unsigned char> encodePng(const Image& img) {
  cv::Mat rgb(img.height, img.width, img.channels == 3 ? CV_8UC3 : CV_8UC1,
              const_cast<uint8_t*>(img.data.data()));
  cv::Mat out;
  if (img.channels == 3)
    cv::cvtColor(rgb, out, cv::COLOR_RGB2BGR);
  else
    out = rgb;
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", out, png))
    throw std::runtime_error("PNG encoding of a tile texture failed");
  return png;
}

struct BufferBuilder {
  tinygltf::Model* model;
  std::vector<unsigned char>& data;
  int view(const void* bytes, std::size_t n, int target) {
    while (data.size() % 4) data.push_back(0);  // accessor alignment
    tinygltf::BufferView bv;
    bv.buffer = 0;
    bv.byteOffset = data.size();
    bv.byteLength = n;
    if (target) bv.target = target;
    const auto* b = static_cast<const unsigned char*>(bytes);
    data.insert(data.end(), b, b + n);
    model->bufferViews.push_back(bv);
    return int(model->bufferViews.size()) - 1;
  }
  int accessor(int view, int component, int type, std::size_t count, std::vector<double> mn = {},
               std::vector<double> mx = {}) {
    tinygltf::Accessor a;
    a.bufferView = view;
    a.byteOffset = 0;
    a.componentType = component;
    a.type = type;
    a.count = count;
    a.minValues = std::move(mn);
    a.maxValues = std::move(mx);
    model->accessors.push_back(a);
    return int(model->accessors.size()) - 1;
  }
};

std::uint64_t pad4(std::uint64_t n) { return (n + 3) & ~std::uint64_t(3); }

}  // namespace

std::uint64_t glbFileBytes(std::uint64_t json_bytes, std::uint64_t bin_bytes) {
  return 12 + 8 + pad4(json_bytes) + (bin_bytes ? 8 + pad4(bin_bytes) : 0);
}

void checkGlbSize(std::uint64_t file_bytes, std::size_t tiles, std::uint64_t max_bytes) {
  if (file_bytes <= max_bytes) return;
  throw std::runtime_error(
      "glTF: " + std::to_string(tiles) + " tile(s) make a .glb of " + byteSize(double(file_bytes)) +
      " (" + std::to_string(file_bytes) + " bytes) or more, meshes and PNG textures together; " +
      "expected at most " + std::to_string(max_bytes) + " bytes" +
      (max_bytes == kMaxGlbBytes ? " (4 GiB - 1: a .glb's lengths are 32-bit)" : "") +
      ". Export formats: [obj, ply] instead (separate files per tile texture), or a smaller "
      "mesh (lower texels_per_cell, decimate: true, or fewer frames per run)");
}

void writeGlb(const std::vector<TileMesh>& tiles, const std::string& path,
              std::uint64_t max_bytes) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "TerraMRF textured terrain mesh (paper 004)";
  model.extensionsUsed.push_back("KHR_materials_unlit");
  model.buffers.resize(1);
  BufferBuilder bb{&model, model.buffers[0].data};

  // Centre of all vertices (double) so the float positions stay precise.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& m : tiles)
    for (const auto& p : m.positions) {
      lo = lo.cwiseMin(Eigen::Vector3d(p[0], p[1], p[2]));
      hi = hi.cwiseMax(Eigen::Vector3d(p[0], p[1], p[2]));
    }
  const Eigen::Vector3d centre =
      tiles.empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(0.5 * (lo + hi));

  tinygltf::Sampler sampler;
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.wrapS = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  model.samplers.push_back(sampler);

  tinygltf::Node root;
  root.name = "terrain";
  root.translation = {centre.x(), centre.z(), -centre.y()};
  tinygltf::Scene scene;

  for (const TileMesh& m : tiles) {
    std::vector<float> pos;
    pos.reserve(m.positions.size() * 3);
    std::vector<double> pmin(3, std::numeric_limits<double>::infinity()), pmax(3, -pmin[0]);
    for (const auto& p : m.positions) {
      const float g[3] = {float(p[0] - centre.x()), float(p[2] - centre.z()),
                          float(-(p[1] - centre.y()))};
      for (int c = 0; c < 3; ++c) {
        pos.push_back(g[c]);
        pmin[c] = std::min(pmin[c], double(g[c]));
        pmax[c] = std::max(pmax[c], double(g[c]));
      }
    }
    std::vector<float> uv;
    uv.reserve(m.uvs.size() * 2);
    for (const auto& t : m.uvs) {
      uv.push_back(t[0]);
      uv.push_back(1.0f - t[1]);  // glTF's v grows downwards in the image
    }
    // World frame is right-handed z-up; the axis swap keeps handedness, so the winding holds.
    std::vector<uint32_t> idx;
    idx.reserve(m.triangles.size() * 3);
    for (const auto& t : m.triangles) idx.insert(idx.end(), t.begin(), t.end());

    const int a_pos = bb.accessor(bb.view(pos.data(), pos.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
                                  TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                                  m.positions.size(), pmin, pmax);
    const int a_uv = bb.accessor(bb.view(uv.data(), uv.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
                                 TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, m.uvs.size());
    const int a_idx =
        bb.accessor(bb.view(idx.data(), idx.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
                    TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, idx.size());

    int material = -1;
    if (m.texture && !m.texture->empty()) {
      const std::vector<unsigned char> png = encodePng(*m.texture);
      tinygltf::Image img;
      img.name = m.name;
      img.mimeType = "image/png";
      img.bufferView = bb.view(png.data(), png.size(), 0);
      model.images.push_back(img);
      tinygltf::Texture tex;
      tex.sampler = 0;
      tex.source = int(model.images.size()) - 1;
      model.textures.push_back(tex);
      tinygltf::Material mat;
      mat.name = m.name;
      mat.pbrMetallicRoughness.baseColorTexture.index = int(model.textures.size()) - 1;
      mat.pbrMetallicRoughness.metallicFactor = 0.0;
      mat.pbrMetallicRoughness.roughnessFactor = 1.0;
      mat.doubleSided = true;
      mat.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object());
      model.materials.push_back(mat);
      material = int(model.materials.size()) - 1;
    }

    tinygltf::Primitive prim;
    prim.attributes["POSITION"] = a_pos;
    prim.attributes["TEXCOORD_0"] = a_uv;
    prim.indices = a_idx;
    prim.material = material;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    tinygltf::Mesh mesh;
    mesh.name = m.name;
    mesh.primitives.push_back(prim);
    model.meshes.push_back(mesh);
    tinygltf::Node node;
    node.name = m.name;
    node.mesh = int(model.meshes.size()) - 1;
    model.nodes.push_back(node);
    root.children.push_back(int(model.nodes.size()) - 1);
    // Stop as soon as the binary chunk alone (geometry and this tile's PNG) is too large, before
    // encoding the rest and before tinygltf's copies of a buffer of several GiB.
    checkGlbSize(glbFileBytes(0, bb.data.size()), model.meshes.size(), max_bytes);
  }
  model.nodes.push_back(root);
  scene.nodes.push_back(int(model.nodes.size()) - 1);
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  model.buffers[0].data.resize((model.buffers[0].data.size() + 3) & ~std::size_t(3), 0);

  // Streamed to the file: an encoded copy of the buffer in memory would double the peak.
  AtomicFileWriter file(path);
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, file.stream(), false, true)) {
    file.checkWritten();  // a full disk names the file; else it was the encoding
    throw std::runtime_error("tinygltf could not encode the glTF model");
  }
  // Every byte went to the file (tinygltf truncates only the length fields it writes), so the
  // count is the file's size, JSON included: above the limit the header would lie about it, and
  // the file is not kept.
  file.checkWritten();
  checkGlbSize(file.bytes(), tiles.size(), max_bytes);
  file.commit();
}

}  // namespace terramrf::meshing

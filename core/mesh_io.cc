#include "core/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/color.h"
#include "core/error.h"
#include "core/input_file.h"

namespace relume {

namespace {

bool Fail(std::string* why, const std::string& reason) {
  if (why != nullptr) *why = reason;
  return false;
}

bool IsFiniteVector(const Eigen::Vector3d& v) {
  return v.allFinite();
}

std::vector<std::string> Tokens(const std::string& line) {
  std::vector<std::string> tokens;
  std::istringstream stream(line);
  std::string token;
  while (stream >> token) tokens.push_back(token);
  return tokens;
}

bool ParseDouble(const std::string& text, double* value) {
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, *value);
  return result.ec == std::errc() && result.ptr == end && std::isfinite(*value);
}

bool ParseInt(const std::string& text, long long* value) {
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, *value);
  return result.ec == std::errc() && result.ptr == end;
}

std::ifstream OpenOrThrow(const std::string& path) {
  return OpenInputFile(path);
}

}  // namespace

void MeshData::Append(const MeshData& other) {
  // Per-face and per-vertex arrays stay aligned; entries a side did not have are NaN, which
  // means "use the object's albedo" (faces) or is filled by the face/object albedo (vertices).
  const Eigen::Vector3d unset = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const bool faces = !face_albedo.empty() || !other.face_albedo.empty();
  const bool materials = !face_material.empty() || !other.face_material.empty();
  const bool per_vertex = !vertex_albedo.empty() || !other.vertex_albedo.empty();
  if (faces) face_albedo.resize(triangles.size(), unset);
  if (materials) face_material.resize(triangles.size());
  if (per_vertex) vertex_albedo.resize(vertices.size(), unset);
  const int base = static_cast<int>(vertices.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (const Eigen::Vector3i& t : other.triangles) triangles.push_back(t + Eigen::Vector3i::Constant(base));
  if (faces) {
    face_albedo.insert(face_albedo.end(), other.face_albedo.begin(), other.face_albedo.end());
    face_albedo.resize(triangles.size(), unset);
  }
  if (materials) {
    face_material.insert(face_material.end(), other.face_material.begin(), other.face_material.end());
    face_material.resize(triangles.size());
  }
  if (per_vertex) {
    vertex_albedo.insert(vertex_albedo.end(), other.vertex_albedo.begin(), other.vertex_albedo.end());
    vertex_albedo.resize(vertices.size(), unset);
  }
}

bool MeshData::IsValid(std::string* why) const {
  if (triangles.empty()) return Fail(why, "the mesh has no triangles");
  for (const Eigen::Vector3d& v : vertices) {
    if (!IsFiniteVector(v)) return Fail(why, "a vertex is not finite");
  }
  const int n = static_cast<int>(vertices.size());
  for (const Eigen::Vector3i& t : triangles) {
    if (t.minCoeff() < 0 || t.maxCoeff() >= n) return Fail(why, "a triangle refers to a vertex that does not exist");
  }
  if (!vertex_albedo.empty() && vertex_albedo.size() != vertices.size()) {
    return Fail(why, "per-vertex albedo must have one value per vertex");
  }
  if (!face_albedo.empty() && face_albedo.size() != triangles.size()) {
    return Fail(why, "per-face albedo must have one value per triangle");
  }
  // NaN entries mean "not given here" (the object's albedo applies).
  auto in_range = [](const Eigen::Vector3d& a) {
    return a.hasNaN() || (a.allFinite() && a.minCoeff() >= 0.0 && a.maxCoeff() <= 1.0);
  };
  for (const auto& a : vertex_albedo) {
    if (!in_range(a)) return Fail(why, "a per-vertex albedo is outside [0, 1]");
  }
  for (const auto& a : face_albedo) {
    if (!in_range(a)) return Fail(why, "a per-face albedo is outside [0, 1]");
  }
  return true;
}

MeshData LoadObjMesh(const std::string& path) {
  std::ifstream stream = OpenOrThrow(path);
  MeshData mesh;
  std::string current_material;
  bool any_material = false;
  bool any_color = false;
  std::string line;
  int line_number = 0;
  while (std::getline(stream, line)) {
    ++line_number;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    const std::vector<std::string> t = Tokens(line);
    if (t.empty()) continue;
    auto fail = [&](const std::string& what) { throw ConfigError(path, line_number, t[0], what); };
    if (t[0] == "v") {
      if (t.size() != 4 && t.size() != 7) fail("expected 'v x y z' or 'v x y z r g b'");
      double values[6] = {0, 0, 0, 0, 0, 0};
      for (std::size_t i = 1; i < t.size(); ++i) {
        if (!ParseDouble(t[i], &values[i - 1])) fail("'" + t[i] + "' is not a finite number");
      }
      mesh.vertices.emplace_back(values[0], values[1], values[2]);
      if (t.size() == 7) {
        const Eigen::Vector3d color(values[3], values[4], values[5]);
        if (color.minCoeff() < 0.0 || color.maxCoeff() > 1.0) fail("vertex colour must be linear in [0, 1]");
        if (!any_color) mesh.vertex_albedo.resize(mesh.vertices.size() - 1, Eigen::Vector3d::Constant(NAN));
        any_color = true;
        mesh.vertex_albedo.push_back(color);
      } else if (any_color) {
        mesh.vertex_albedo.push_back(Eigen::Vector3d::Constant(NAN));
      }
    } else if (t[0] == "f") {
      if (t.size() < 4) fail("a face needs at least 3 vertices");
      std::vector<int> indices;
      for (std::size_t i = 1; i < t.size(); ++i) {
        const std::string first = t[i].substr(0, t[i].find('/'));
        long long index = 0;
        if (!ParseInt(first, &index) || index == 0) fail("'" + t[i] + "' is not a vertex index (1-based)");
        const long long count = static_cast<long long>(mesh.vertices.size());
        const long long zero_based = index > 0 ? index - 1 : count + index;
        if (zero_based < 0 || zero_based >= count) {
          fail("vertex " + std::to_string(index) + " does not exist (" + std::to_string(count) + " so far)");
        }
        indices.push_back(static_cast<int>(zero_based));
      }
      for (std::size_t i = 1; i + 1 < indices.size(); ++i) {
        mesh.triangles.emplace_back(indices[0], indices[i], indices[i + 1]);
        mesh.face_material.push_back(current_material);
      }
    } else if (t[0] == "usemtl") {
      if (t.size() != 2) fail("expected 'usemtl NAME'");
      current_material = t[1];
      any_material = true;
    }
  }
  if (!any_material) mesh.face_material.clear();
  if (mesh.triangles.empty()) throw ConfigError(path, line_number, "f", "the OBJ file has no faces");
  return mesh;
}

namespace {

struct PlyProperty {
  std::string name;
  std::string type;  // scalar type, or the item type of a list
  bool is_list = false;
};
struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> properties;
};

bool IsIntegerType(const std::string& type) {
  return type == "char" || type == "uchar" || type == "short" || type == "ushort" || type == "int" || type == "uint" ||
         type == "int8" || type == "uint8" || type == "int16" || type == "uint16" || type == "int32" ||
         type == "uint32";
}

double ColorValue(double raw, const std::string& type) {
  if (IsIntegerType(type)) return SrgbDecode(raw / 255.0);
  return raw;
}

}  // namespace

MeshData LoadPlyMesh(const std::string& path) {
  std::ifstream stream = OpenOrThrow(path);
  std::string line;
  int line_number = 0;
  auto next_line = [&]() -> bool {
    if (!std::getline(stream, line)) return false;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  };
  if (!next_line() || line != "ply") throw ConfigError(path, 1, "ply", "not a PLY file (the first line must be 'ply')");
  std::vector<PlyElement> elements;
  bool ascii = false;
  while (true) {
    if (!next_line()) throw ConfigError(path, line_number, "end_header", "the header never ends");
    const std::vector<std::string> t = Tokens(line);
    if (t.empty()) continue;
    auto fail = [&](const std::string& what) { throw ConfigError(path, line_number, t[0], what); };
    if (t[0] == "end_header") break;
    if (t[0] == "comment" || t[0] == "obj_info") continue;
    if (t[0] == "format") {
      if (t.size() < 2 || t[1] != "ascii") fail("only 'format ascii 1.0' is supported; convert binary PLY to ASCII");
      ascii = true;
    } else if (t[0] == "element") {
      long long count = 0;
      if (t.size() != 3 || !ParseInt(t[2], &count) || count < 0) fail("expected 'element NAME COUNT'");
      elements.push_back({t[1], count, {}});
    } else if (t[0] == "property") {
      if (elements.empty()) fail("a property before any element");
      if (t.size() == 3) {
        elements.back().properties.push_back({t[2], t[1], false});
      } else if (t.size() == 5 && t[1] == "list") {
        elements.back().properties.push_back({t[4], t[3], true});
      } else {
        fail("expected 'property TYPE NAME' or 'property list COUNT_TYPE ITEM_TYPE NAME'");
      }
    } else {
      fail("unknown header statement");
    }
  }
  if (!ascii) throw ConfigError(path, line_number, "format", "missing 'format ascii 1.0'");

  MeshData mesh;
  for (const PlyElement& element : elements) {
    auto find = [&](const char* name) {
      for (std::size_t i = 0; i < element.properties.size(); ++i) {
        if (element.properties[i].name == name) return static_cast<int>(i);
      }
      return -1;
    };
    const int ix = find("x"), iy = find("y"), iz = find("z");
    const int ir = find("red"), ig = find("green"), ib = find("blue");
    int ilist = find("vertex_indices");
    if (ilist < 0) ilist = find("vertex_index");
    const bool is_vertex = element.name == "vertex";
    const bool is_face = element.name == "face";
    if (is_vertex && (ix < 0 || iy < 0 || iz < 0)) {
      throw ConfigError(path, line_number, "vertex", "the vertex element needs x, y and z properties");
    }
    if (is_face && ilist < 0) {
      throw ConfigError(path, line_number, "face", "the face element needs a vertex_indices list");
    }
    const bool has_color = ir >= 0 && ig >= 0 && ib >= 0;
    for (long long n = 0; n < element.count; ++n) {
      if (!next_line()) {
        throw ConfigError(path, line_number, element.name,
                          "the file ends after " + std::to_string(n) + " of " + std::to_string(element.count) + " " +
                              element.name + " lines");
      }
      const std::vector<std::string> t = Tokens(line);
      auto fail = [&](const std::string& what) { throw ConfigError(path, line_number, element.name, what); };
      std::size_t cursor = 0;
      std::vector<double> scalars(element.properties.size(), 0.0);
      std::vector<long long> list;
      for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        if (property.is_list) {
          long long count = 0;
          if (cursor >= t.size() || !ParseInt(t[cursor], &count) || count < 0) fail("bad list length");
          ++cursor;
          std::vector<long long> items;
          for (long long k = 0; k < count; ++k) {
            long long item = 0;
            if (cursor >= t.size() || !ParseInt(t[cursor], &item)) fail("bad list item");
            ++cursor;
            items.push_back(item);
          }
          if (static_cast<int>(p) == ilist) list = std::move(items);
        } else {
          double value = 0.0;
          if (cursor >= t.size() || !ParseDouble(t[cursor], &value)) {
            fail("missing or bad value for property '" + property.name + "'");
          }
          ++cursor;
          scalars[p] = value;
        }
      }
      if (cursor != t.size()) fail("more values than the header's properties");
      const auto color = [&]() {
        const std::string& type = element.properties[static_cast<std::size_t>(ir)].type;
        Eigen::Vector3d c(ColorValue(scalars[static_cast<std::size_t>(ir)], type),
                          ColorValue(scalars[static_cast<std::size_t>(ig)], type),
                          ColorValue(scalars[static_cast<std::size_t>(ib)], type));
        if (c.minCoeff() < 0.0 || c.maxCoeff() > 1.0) fail("colour outside [0, 1] (uchar 0..255 or float 0..1)");
        return c;
      };
      if (is_vertex) {
        mesh.vertices.emplace_back(scalars[static_cast<std::size_t>(ix)], scalars[static_cast<std::size_t>(iy)],
                                   scalars[static_cast<std::size_t>(iz)]);
        if (has_color) mesh.vertex_albedo.push_back(color());
      } else if (is_face) {
        if (list.size() < 3) fail("a face needs at least 3 vertices");
        for (long long index : list) {
          if (index < 0 || index >= static_cast<long long>(mesh.vertices.size())) {
            fail("vertex index " + std::to_string(index) + " does not exist");
          }
        }
        for (std::size_t i = 1; i + 1 < list.size(); ++i) {
          mesh.triangles.emplace_back(static_cast<int>(list[0]), static_cast<int>(list[i]),
                                      static_cast<int>(list[i + 1]));
          if (has_color) mesh.face_albedo.push_back(color());
        }
      }
    }
  }
  if (mesh.triangles.empty()) throw ConfigError(path, line_number, "face", "the PLY file has no faces");
  return mesh;
}

MeshData LoadMesh(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".obj") return LoadObjMesh(path);
  if (extension == ".ply") return LoadPlyMesh(path);
  throw InvalidArgumentError("mesh '" + path + "': unknown format '" + extension + "'; use .obj or .ply");
}

}  // namespace relume

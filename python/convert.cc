#include "python/convert.h"

#include <cstdint>
#include <cstring>

#include "core/error.h"
#include "python/numpy_mat.h"

namespace py = pybind11;

namespace relume::python {

Eigen::Vector3d Vector3FromPython(const py::handle& value, const std::string& what) {
  const auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!array || array.size() != 3) throw InvalidArgumentError(what + ": expected 3 numbers");
  const double* p = array.data();
  return {p[0], p[1], p[2]};
}

namespace {

py::object Item(const py::handle& dict, const char* key, const std::string& what) {
  if (!py::isinstance<py::dict>(dict)) throw InvalidArgumentError(what + ": expected a dict");
  const py::dict d = py::reinterpret_borrow<py::dict>(dict);
  if (!d.contains(key)) throw InvalidArgumentError(what + ": missing key '" + key + "'");
  return d[key];
}

}  // namespace

PinholeIntrinsics IntrinsicsFromPython(const py::handle& camera, const std::string& what) {
  PinholeIntrinsics k;
  k.width = Item(camera, "width", what).cast<int>();
  k.height = Item(camera, "height", what).cast<int>();
  k.fx = Item(camera, "fx", what).cast<double>();
  k.fy = Item(camera, "fy", what).cast<double>();
  k.cx = Item(camera, "cx", what).cast<double>();
  k.cy = Item(camera, "cy", what).cast<double>();
  std::string why;
  if (!k.IsValid(&why)) throw InvalidArgumentError(what + ": " + why);
  return k;
}

PinholeCamera CameraFromPython(const py::handle& camera, const std::string& what) {
  PinholeCamera c;
  c.intrinsics = IntrinsicsFromPython(camera, what);
  const auto pose =
      py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(Item(camera, "world_from_camera", what));
  if (!pose || pose.ndim() != 2 || pose.shape(0) != 4 || pose.shape(1) != 4) {
    throw InvalidArgumentError(what + "['world_from_camera']: expected a 4x4 matrix");
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int col = 0; col < 4; ++col) m(r, col) = pose.at(r, col);
  }
  if (!m.allFinite() || (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9 ||
      !(m.topLeftCorner<3, 3>().transpose() * m.topLeftCorner<3, 3>()).isIdentity(1e-6)) {
    throw InvalidArgumentError(what + "['world_from_camera']: expected a rigid transform (rotation and translation)");
  }
  c.world_from_camera.matrix() = m;
  return c;
}

py::dict CameraToPython(const PinholeCamera& camera) {
  const PinholeIntrinsics& k = camera.intrinsics;
  py::array_t<double> pose({4, 4});
  auto view = pose.mutable_unchecked<2>();
  const Eigen::Matrix4d m = camera.world_from_camera.matrix();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) view(r, c) = m(r, c);
  }
  py::dict d;
  d["width"] = k.width;
  d["height"] = k.height;
  d["fx"] = k.fx;
  d["fy"] = k.fy;
  d["cx"] = k.cx;
  d["cy"] = k.cy;
  d["world_from_camera"] = pose;
  return d;
}

py::array_t<float> Vectors3fToArray(const std::vector<Eigen::Vector3f>& v) {
  py::array_t<float> out({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(Eigen::Vector3f));
  return out;
}

std::vector<Eigen::Vector3f> Vectors3fFromArray(const py::handle& array, const std::string& what) {
  const auto a = ContiguousArray<float>(py::array::ensure(array), what);
  if (a.ndim() != 2 || a.shape(1) != 3) throw InvalidArgumentError(what + ": expected an (N, 3) float32 array");
  std::vector<Eigen::Vector3f> v(static_cast<std::size_t>(a.shape(0)));
  const float* p = a.data();
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = Eigen::Vector3f(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  return v;
}

py::array_t<double> Vectors3dToArray(const std::vector<Eigen::Vector3d>& v) {
  py::array_t<double> out({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(Eigen::Vector3d));
  return out;
}

std::vector<Eigen::Vector3d> Vectors3dFromArray(const py::handle& array, const std::string& what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
  if (!a || a.ndim() != 2 || a.shape(1) != 3) throw InvalidArgumentError(what + ": expected an (N, 3) array");
  std::vector<Eigen::Vector3d> v(static_cast<std::size_t>(a.shape(0)));
  const double* p = a.data();
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  return v;
}

TriangleMesh MeshFromPython(const py::handle& mesh, const std::string& what) {
  TriangleMesh m;
  m.positions = Vectors3fFromArray(Item(mesh, "positions", what), what + "['positions']");
  const auto triangles =
      ContiguousArray<std::int32_t>(py::array::ensure(Item(mesh, "triangles", what)), what + "['triangles']");
  if (triangles.ndim() != 2 || triangles.shape(1) != 3) {
    throw InvalidArgumentError(what + "['triangles']: expected an (M, 3) int32 array");
  }
  m.triangles.resize(static_cast<std::size_t>(triangles.shape(0)));
  const std::int32_t* t = triangles.data();
  for (std::size_t i = 0; i < m.triangles.size(); ++i)
    m.triangles[i] = Eigen::Vector3i(t[3 * i], t[3 * i + 1], t[3 * i + 2]);
  const py::dict d = py::reinterpret_borrow<py::dict>(mesh);
  if (d.contains("normals") && !d["normals"].is_none()) {
    m.normals = Vectors3fFromArray(d["normals"], what + "['normals']");
  }
  if (d.contains("parts") && !d["parts"].is_none()) {
    const auto parts = ContiguousArray<std::int32_t>(py::array::ensure(d["parts"]), what + "['parts']");
    if (parts.ndim() != 1) throw InvalidArgumentError(what + "['parts']: expected an (N,) int32 array");
    m.part.assign(parts.data(), parts.data() + parts.shape(0));
  }
  std::string why;
  if (!m.IsValid(&why)) throw InvalidArgumentError(what + ": " + why);
  return m;
}

py::dict MeshToPython(const TriangleMesh& mesh) {
  py::array_t<std::int32_t> triangles({static_cast<py::ssize_t>(mesh.triangles.size()), py::ssize_t{3}});
  if (!mesh.triangles.empty()) {
    std::memcpy(triangles.mutable_data(), mesh.triangles.data(), mesh.triangles.size() * sizeof(Eigen::Vector3i));
  }
  py::dict d;
  d["positions"] = Vectors3fToArray(mesh.positions);
  d["triangles"] = triangles;
  d["normals"] = mesh.normals.empty() ? py::object(py::none()) : py::object(Vectors3fToArray(mesh.normals));
  if (mesh.part.empty()) {
    d["parts"] = py::none();
  } else {
    py::array_t<std::int32_t> parts(static_cast<py::ssize_t>(mesh.part.size()));
    std::memcpy(parts.mutable_data(), mesh.part.data(), mesh.part.size() * sizeof(std::int32_t));
    d["parts"] = parts;
  }
  return d;
}

cv::Mat FloatMatFromArray(const py::handle& array, int channels, const std::string& what, py::array* keep) {
  const py::array a = py::array::ensure(array);
  if (!a) throw InvalidArgumentError(what + ": not an array");
  *keep = ContiguousArray<float>(a, what);
  const bool shape_ok = channels == 1 ? keep->ndim() == 2 : keep->ndim() == 3 && keep->shape(2) == channels;
  if (!shape_ok) {
    throw InvalidArgumentError(what + (channels == 1
                                           ? ": expected an HxW float32 array"
                                           : ": expected an HxWx" + std::to_string(channels) + " float32 array"));
  }
  return MatView(*keep, what);
}

RadianceImage RadianceFromArray(const py::handle& array, const std::string& what, py::array* keep) {
  RadianceImage image;
  image.pixels = FloatMatFromArray(array, 3, what, keep);
  return image;
}

cv::Mat MaskFromPython(const py::handle& mask, const std::string& what, py::array* keep) {
  if (mask.is_none()) return {};
  py::array a = py::array::ensure(mask);
  if (!a || a.ndim() != 2) throw InvalidArgumentError(what + ": expected an HxW bool or uint8 array");
  if (a.dtype().equal(py::dtype::of<bool>())) a = a.attr("astype")(py::dtype::of<std::uint8_t>());
  *keep = ContiguousArray<std::uint8_t>(a, what);
  return MatView(*keep, what);
}

}  // namespace relume::python

// Conversions between Python values and relume's geometry types, shared by the array bindings.
//
//  - Vectors: any sequence or array of 3 numbers. Matrices: a 2-D array of the stated shape.
//  - Cameras: a dict {'width', 'height', 'fx', 'fy', 'cx', 'cy' (pixels, continuous coordinates,
//    pixel centres at +0.5; core/pinhole.h), 'world_from_camera' (4x4, camera x right, y down,
//    z forward)}; the dict Session.camera returns. Intrinsics alone: the same dict without the pose.
//  - Meshes: a dict {'positions' (N, 3) float32 metres, 'triangles' (M, 3) int32 (counter-clockwise
//    seen from the front), 'normals' (N, 3) float32 unit or absent}; the dict Session.scene_mesh
//    returns. Copied in and out (Embree takes its own copy anyway).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "core/pinhole.h"

namespace relume::python {

Eigen::Vector3d Vector3FromPython(const pybind11::handle& value, const std::string& what);

PinholeIntrinsics IntrinsicsFromPython(const pybind11::handle& camera, const std::string& what);
PinholeCamera CameraFromPython(const pybind11::handle& camera, const std::string& what);
pybind11::dict CameraToPython(const PinholeCamera& camera);

TriangleMesh MeshFromPython(const pybind11::handle& mesh, const std::string& what);
pybind11::dict MeshToPython(const TriangleMesh& mesh);

// An (N, 3) float32 array from per-element vectors, and back (N rows of 3; copies).
pybind11::array_t<float> Vectors3fToArray(const std::vector<Eigen::Vector3f>& v);
std::vector<Eigen::Vector3f> Vectors3fFromArray(const pybind11::handle& array, const std::string& what);
pybind11::array_t<double> Vectors3dToArray(const std::vector<Eigen::Vector3d>& v);
std::vector<Eigen::Vector3d> Vectors3dFromArray(const pybind11::handle& array, const std::string& what);

// A float32 HxWx3 array as a RadianceImage over its buffer (kept alive by `keep`), copying only
// when it is not C-contiguous. InvalidArgumentError for other shapes or dtypes.
RadianceImage RadianceFromArray(const pybind11::handle& array, const std::string& what, pybind11::array* keep);
// A float32 HxW or HxWxC array of `channels` channels as a cv::Mat over its buffer.
cv::Mat FloatMatFromArray(const pybind11::handle& array, int channels, const std::string& what, pybind11::array* keep);
// An optional mask: None -> empty Mat; bool or uint8 HxW -> CV_8UC1 (non-zero = set), copied to uint8.
cv::Mat MaskFromPython(const pybind11::handle& mask, const std::string& what, pybind11::array* keep);

}  // namespace relume::python

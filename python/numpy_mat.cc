#include "python/numpy_mat.h"

#include <cstdint>
#include <vector>

#include "core/error.h"

namespace py = pybind11;

namespace relume::python {

template <typename T>
py::array_t<T, py::array::c_style> ContiguousArray(const py::array& array, const std::string& what) {
  if (!array.dtype().equal(py::dtype::of<T>())) {
    throw InvalidArgumentError(what + ": expected dtype " +
                               py::dtype::of<T>().attr("name").template cast<std::string>() + ", got " +
                               array.dtype().attr("name").template cast<std::string>());
  }
  // Copies only when the array is not C-contiguous already.
  return py::array_t<T, py::array::c_style>::ensure(array);
}

template py::array_t<std::uint8_t, py::array::c_style> ContiguousArray(const py::array&, const std::string&);
template py::array_t<std::uint16_t, py::array::c_style> ContiguousArray(const py::array&, const std::string&);
template py::array_t<std::int32_t, py::array::c_style> ContiguousArray(const py::array&, const std::string&);
template py::array_t<float, py::array::c_style> ContiguousArray(const py::array&, const std::string&);
template py::array_t<double, py::array::c_style> ContiguousArray(const py::array&, const std::string&);

namespace {

int CvDepth(const py::dtype& dtype, const std::string& what) {
  if (dtype.equal(py::dtype::of<std::uint8_t>())) return CV_8U;
  if (dtype.equal(py::dtype::of<std::uint16_t>())) return CV_16U;
  if (dtype.equal(py::dtype::of<float>())) return CV_32F;
  throw InvalidArgumentError(what + ": expected dtype uint8, uint16 or float32, got " +
                             dtype.attr("name").cast<std::string>());
}

py::dtype NumpyType(int cv_depth) {
  switch (cv_depth) {
    case CV_8U: return py::dtype::of<std::uint8_t>();
    case CV_16U: return py::dtype::of<std::uint16_t>();
    case CV_32S: return py::dtype::of<std::int32_t>();
    case CV_32F: return py::dtype::of<float>();
    case CV_64F: return py::dtype::of<double>();
    default: throw Error("an image of OpenCV depth " + std::to_string(cv_depth) + " has no numpy dtype here");
  }
}

}  // namespace

cv::Mat MatView(const py::array& contiguous, const std::string& what) {
  if (contiguous.ndim() != 2 && contiguous.ndim() != 3) {
    throw InvalidArgumentError(what + ": expected an HxW or HxWxC array, got " + std::to_string(contiguous.ndim()) +
                               " dimensions");
  }
  const int channels = contiguous.ndim() == 3 ? static_cast<int>(contiguous.shape(2)) : 1;
  if (channels < 1 || channels > 4) {
    throw InvalidArgumentError(what + ": expected 1 to 4 channels, got " + std::to_string(channels));
  }
  const int depth = CvDepth(contiguous.dtype(), what);
  // cv::Mat takes a non-const pointer; relume's calls only read their inputs.
  void* data = const_cast<void*>(contiguous.data());
  return cv::Mat(static_cast<int>(contiguous.shape(0)), static_cast<int>(contiguous.shape(1)),
                 CV_MAKETYPE(depth, channels), data);
}

py::array MatToArray(cv::Mat mat) {
  const py::dtype dtype = NumpyType(mat.depth());
  auto* owner = new cv::Mat(std::move(mat));
  py::capsule capsule(owner, [](void* p) { delete static_cast<cv::Mat*>(p); });
  const auto element = static_cast<py::ssize_t>(owner->elemSize1());
  std::vector<py::ssize_t> shape = {owner->rows, owner->cols};
  std::vector<py::ssize_t> strides = {static_cast<py::ssize_t>(owner->step[0]),
                                      static_cast<py::ssize_t>(owner->elemSize())};
  if (owner->channels() > 1) {
    shape.push_back(owner->channels());
    strides.push_back(element);
  }
  return py::array(dtype, shape, strides, owner->data, capsule);
}

}  // namespace relume::python

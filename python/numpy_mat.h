// numpy arrays as cv::Mat and back, without copies where the layout allows.
//
//  - In: a C-contiguous array is wrapped in a cv::Mat header over its own buffer (the array must
//    outlive the header: callers keep the py::array). Other layouts are copied once into a
//    C-contiguous array first. Shapes: HxW (one channel) or HxWxC (C channels, RGB order).
//  - Out: the cv::Mat is moved into a heap copy owned by a capsule, and the array views its
//    pixels (rows may be padded: the array's strides are the Mat's steps).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <opencv2/core/mat.hpp>
#include <string>

namespace relume::python {

// The array as a C-contiguous one of dtype T, copying only when needed. `what` names the
// argument in errors (InvalidArgumentError when the dtype is not T: no silent conversion).
template <typename T>
pybind11::array_t<T, pybind11::array::c_style> ContiguousArray(const pybind11::array& array, const std::string& what);

// A cv::Mat header over a C-contiguous 2-D (HxW) or 3-D (HxWxC) array of uint8, uint16 or
// float32. InvalidArgumentError for other shapes or dtypes.
cv::Mat MatView(const pybind11::array& contiguous, const std::string& what);

// The Mat's pixels as a numpy array (HxW for one channel, HxWxC otherwise) owning the Mat.
pybind11::array MatToArray(cv::Mat mat);

}  // namespace relume::python

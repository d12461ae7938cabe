// The `relume` Python module: numpy in and out, relume's errors as Python exceptions.
#include <pybind11/pybind11.h>

#include "python/bindings.h"

PYBIND11_MODULE(relume, m) {
  m.doc() =
      "relume: sun positions, HDR calibration and merging, recorded sessions and the processing\n"
      "pipelines, and the processing and calibration functions on numpy arrays (IRM relighting,\n"
      "depth filters and normals, SH lighting, the ColorChecker, radiosity and reflectance), from\n"
      "Python (a binding of relume's library; docs/python.md). Options are keyword arguments checked\n"
      "by the library before any work.\n\n"
      "Errors raise relume.Error subclasses carrying relume's messages: InvalidArgumentError\n"
      "(also a ValueError), ConfigError (also a ValueError) and IoError (also an OSError).";
  relume::python::BindErrors(m);
  relume::python::BindSun(m);
  relume::python::BindHdr(m);
  relume::python::BindSession(m);
  relume::python::BindProcess(m);
  relume::python::BindIrm(m);
  relume::python::BindDepth(m);
  relume::python::BindSh(m);
  relume::python::BindColor(m);
  relume::python::BindRadiosity(m);
}

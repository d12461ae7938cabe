// relume's exceptions (core/error.h) as Python exceptions with the same messages:
//   relume.Error                 <- relume::Error (every error a user can cause)
//   relume.InvalidArgumentError  <- relume::InvalidArgumentError, also a ValueError
//   relume.ConfigError           <- relume::ConfigError, also a ValueError; .file .line .key
//   relume.IoError               <- relume::IoError, also an OSError; .path .reason
#include <Python.h>

#include <exception>
#include <string>

#include "core/error.h"
#include "python/bindings.h"

namespace py = pybind11;

namespace relume::python {

namespace {

// The exception classes live as long as the interpreter (module attributes hold them too).
PyObject* error_type = nullptr;
PyObject* invalid_argument_type = nullptr;
PyObject* config_error_type = nullptr;
PyObject* io_error_type = nullptr;

PyObject* NewExceptionType(py::module_& m, const char* name, py::tuple bases, const char* doc) {
  const std::string qualified = std::string("relume.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr);
  if (type == nullptr) throw py::error_already_set();
  m.add_object(name, py::reinterpret_borrow<py::object>(type));
  return type;
}

// Raises `type(message)` with the given attributes set on the instance.
void Raise(PyObject* type, const char* message, const py::dict& attributes) {
  py::object instance = py::reinterpret_borrow<py::object>(type)(message);
  for (const auto& [key, value] : attributes) py::setattr(instance, key, value);
  PyErr_SetObject(type, instance.ptr());
}

}  // namespace

void BindErrors(py::module_& m) {
  py::handle exception(PyExc_Exception);
  py::handle value_error(PyExc_ValueError);
  py::handle os_error(PyExc_OSError);
  error_type = NewExceptionType(m, "Error", py::make_tuple(exception),
                                "Base of every relume error a user can cause; the message says what is wrong.");
  py::handle base(error_type);
  invalid_argument_type = NewExceptionType(m, "InvalidArgumentError", py::make_tuple(base, value_error),
                                           "A value passed to relume is out of range or malformed.");
  config_error_type = NewExceptionType(m, "ConfigError", py::make_tuple(base, value_error),
                                       "A configuration file is wrong: attributes file, line and key.");
  io_error_type = NewExceptionType(m, "IoError", py::make_tuple(base, os_error),
                                   "A file or folder could not be read or written: attributes path and reason.");
  py::register_exception_translator([](std::exception_ptr p) {
    if (!p) return;
    try {
      std::rethrow_exception(p);
    } catch (const ConfigError& e) {
      py::dict attributes;
      attributes["file"] = e.file();
      attributes["line"] = e.line();
      attributes["key"] = e.key();
      Raise(config_error_type, e.what(), attributes);
    } catch (const IoError& e) {
      py::dict attributes;
      attributes["path"] = e.path();
      attributes["reason"] = e.reason();
      Raise(io_error_type, e.what(), attributes);
    } catch (const InvalidArgumentError& e) {
      Raise(invalid_argument_type, e.what(), py::dict());
    } catch (const Error& e) {
      Raise(error_type, e.what(), py::dict());
    }
  });
}

py::object JsonToPython(const std::string& json_text) {
  return py::module_::import("json").attr("loads")(json_text);
}

}  // namespace relume::python

// A pipeline's summary (summary.json "metrics") and the records its stages write, declared once
// as typed fields.
//
// Each summary or record is a struct with a member template that lists its fields, as knobs.h
// does for knobs (a type of another layer: a free VisitFields(V&, T&) in its namespace):
//
//   struct BracketSummary {
//     std::string device;
//     std::optional<double> truth_relative_rms;  // absent: not compared
//     template <typename V>
//     void VisitFields(V& v) {
//       v.Field("device", device);
//       v.Field("truth_relative_rms", truth_relative_rms);
//     }
//   };
//
// FieldsToJson writes it (JSON exists only at the edge: summary.json, a stage's record file);
// FieldsFromJson reads it back, so a reused stage's record, a summary an earlier run wrote and a
// fresh run go through the same fields. The pipelines compute with the typed values; the headline
// and the report's figures read them, never JSON keys spelled twice.
//
// Field types: bool, int, std::int64_t, float, double, std::string, Eigen fixed-size vectors,
// std::optional<T> (absent: the key is left out; null or missing: nullopt), std::vector<T>,
// std::array<T, N>, std::map<std::string, T>, and structs with VisitFields. A non-finite float or double is
// written as null and read back as NaN. Reading is lenient about missing keys (the field keeps
// its default: an older file lacks newer figures) and strict about types: a key holding the
// wrong kind of value is an IoError naming the field's path and what it expects.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "core/error.h"

namespace relume::pipeline {

namespace fields_internal {

template <typename T>
concept HasMemberFields = requires(T& t, int& v) {
  t.template VisitFields<int>(v);
};
// A struct of another layer (processing's result types) gets its field list as a free function
// template in its own namespace, found by argument-dependent lookup:
//   namespace relume::metrics { template <typename V> void VisitFields(V& v, SunRegionErrors& e); }
template <typename T>
concept HasFreeFields = requires(T& t, int& v) {
  VisitFields(v, t);
};
template <typename T>
concept HasFields = HasMemberFields<T> || HasFreeFields<T>;

template <typename V, typename T>
void VisitFieldsOf(V& v, T& value) {
  if constexpr (HasMemberFields<T>) {
    value.VisitFields(v);
  } else {
    VisitFields(v, value);
  }
}

// Thrown by Decode, and turned by FieldsFromJson into an IoError that names the file.
struct WrongFieldType {
  std::string message;
};
[[noreturn]] inline void ThrowWrongType(const std::string& path, const char* expected, const nlohmann::json& value) {
  throw WrongFieldType{"field '" + path + "' holds " + std::string(value.type_name()) + "; expected " + expected +
                       " (written by another version of relume? rerun with --force)"};
}

template <typename T>
struct IsOptional : std::false_type {};
template <typename T>
struct IsOptional<std::optional<T>> : std::true_type {};
template <typename T>
struct IsVector : std::false_type {};
template <typename T>
struct IsVector<std::vector<T>> : std::true_type {};
template <typename T>
struct IsArray : std::false_type {};
template <typename T, std::size_t N>
struct IsArray<std::array<T, N>> : std::true_type {};
template <typename T>
struct IsStringMap : std::false_type {};
template <typename T>
struct IsStringMap<std::map<std::string, T>> : std::true_type {};
template <typename T>
struct IsEigenVector : std::false_type {};
template <typename S, int N>
struct IsEigenVector<Eigen::Matrix<S, N, 1>> : std::true_type {};

template <typename T>
nlohmann::json Encode(const T& value);
template <typename T>
void Decode(const nlohmann::json& j, const std::string& path, T* value);

struct Writer {
  nlohmann::json& json;
  template <typename T>
  void Field(const char* name, T& value) {
    if constexpr (IsOptional<T>::value) {
      if (value) json[name] = Encode(*value);
    } else {
      json[name] = Encode(value);
    }
  }
};

struct Reader {
  const nlohmann::json& json;
  const std::string& path;
  template <typename T>
  void Field(const char* name, T& value) {
    const auto it = json.find(name);
    if (it == json.end()) return;
    Decode(*it, path.empty() ? std::string(name) : path + "." + name, &value);
  }
};

template <typename T>
nlohmann::json Encode(const T& value) {
  if constexpr (std::is_floating_point_v<T>) {
    return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
  } else if constexpr (std::is_same_v<T, bool> || std::is_integral_v<T> || std::is_same_v<T, std::string>) {
    return nlohmann::json(value);
  } else if constexpr (IsOptional<T>::value) {
    return value ? Encode(*value) : nlohmann::json();
  } else if constexpr (IsEigenVector<T>::value) {
    nlohmann::json out = nlohmann::json::array();
    for (int i = 0; i < value.size(); ++i) out.push_back(Encode(value[i]));
    return out;
  } else if constexpr (IsVector<T>::value || IsArray<T>::value) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& element : value) out.push_back(Encode(element));
    return out;
  } else if constexpr (IsStringMap<T>::value) {
    nlohmann::json out = nlohmann::json::object();
    for (const auto& [key, element] : value) out[key] = Encode(element);
    return out;
  } else {
    static_assert(HasFields<T>, "a summary field must be a number, bool, text, vector, map, optional or fields");
    nlohmann::json out = nlohmann::json::object();
    Writer writer{out};
    // VisitFields takes its fields by reference; the writer only reads them (no copy of a large
    // record such as an IRM set).
    VisitFieldsOf(writer, const_cast<T&>(value));
    return out;
  }
}

template <typename T>
void Decode(const nlohmann::json& j, const std::string& path, T* value) {
  if constexpr (std::is_same_v<T, bool>) {
    if (!j.is_boolean()) ThrowWrongType(path, "true or false", j);
    *value = j.get<bool>();
  } else if constexpr (std::is_floating_point_v<T>) {
    if (j.is_null()) {
      *value = std::numeric_limits<T>::quiet_NaN();
      return;
    }
    if (!j.is_number()) ThrowWrongType(path, "a number", j);
    *value = j.get<T>();
  } else if constexpr (std::is_integral_v<T>) {
    if (!j.is_number_integer()) ThrowWrongType(path, "an integer", j);
    *value = j.get<T>();
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!j.is_string()) ThrowWrongType(path, "text", j);
    *value = j.get<std::string>();
  } else if constexpr (IsOptional<T>::value) {
    if (j.is_null()) {
      value->reset();
      return;
    }
    typename T::value_type inner{};
    Decode(j, path, &inner);
    *value = std::move(inner);
  } else if constexpr (IsEigenVector<T>::value) {
    if (!j.is_array() || static_cast<int>(j.size()) != value->size()) {
      ThrowWrongType(path, "an array of numbers of the vector's size", j);
    }
    for (int i = 0; i < value->size(); ++i) Decode(j[static_cast<std::size_t>(i)], path, &(*value)[i]);
  } else if constexpr (IsVector<T>::value) {
    if (!j.is_array()) ThrowWrongType(path, "an array", j);
    value->clear();
    value->resize(j.size());
    for (std::size_t i = 0; i < j.size(); ++i) Decode(j[i], path + "[" + std::to_string(i) + "]", &(*value)[i]);
  } else if constexpr (IsArray<T>::value) {
    if (!j.is_array() || j.size() != value->size()) ThrowWrongType(path, "an array of the fixed size", j);
    for (std::size_t i = 0; i < j.size(); ++i) Decode(j[i], path + "[" + std::to_string(i) + "]", &(*value)[i]);
  } else if constexpr (IsStringMap<T>::value) {
    if (!j.is_object()) ThrowWrongType(path, "an object", j);
    value->clear();
    for (const auto& [key, element] : j.items()) Decode(element, path + "." + key, &(*value)[key]);
  } else {
    static_assert(HasFields<T>, "a summary field must be a number, bool, text, vector, map, optional or fields");
    if (!j.is_object()) ThrowWrongType(path, "an object", j);
    Reader reader{j, path};
    VisitFieldsOf(reader, *value);
  }
}

}  // namespace fields_internal

// The fields of `value` as a JSON object (optional fields without a value left out).
template <typename T>
nlohmann::json FieldsToJson(const T& value) {
  return fields_internal::Encode(value);
}

// Reads `json` into a T: fields it lacks keep their defaults. IoError naming `source` (the file it
// came from) and the field's path when a field holds the wrong kind of value.
template <typename T>
T FieldsFromJson(const nlohmann::json& json, const std::string& source) {
  T value{};
  try {
    fields_internal::Decode(json, "", &value);
  } catch (const fields_internal::WrongFieldType& e) {
    throw IoError(source, e.message);
  }
  return value;
}

// A JSON file: written whole (IoError when it cannot be), read back (IoError naming the file when
// it is missing or not JSON, with `remedy`: by default for a stage output someone removed or cut
// short).
void WriteJsonFile(const std::filesystem::path& path, const nlohmann::json& json);
nlohmann::json ReadJsonFile(const std::filesystem::path& path,
                            const std::string& remedy = "a stage output is missing or cut short: rerun with --force");

// A stage's record (a struct with VisitFields) as its JSON file, and back.
template <typename T>
void WriteRecord(const std::filesystem::path& path, const T& record) {
  WriteJsonFile(path, FieldsToJson(record));
}
template <typename T>
T ReadRecord(const std::filesystem::path& path) {
  return FieldsFromJson<T>(ReadJsonFile(path), path.string());
}

}  // namespace relume::pipeline

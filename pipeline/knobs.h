// A pipeline's knobs (`relume process --set KEY=VALUE`), declared once.
//
// Each pipeline keeps its knobs in one struct with a member template that lists them:
//
//   struct IrmKnobs {
//     int bins = 32;
//     bool compare_truth = true;
//     template <typename V>
//     void VisitKnobs(V& v) {
//       v.Knob("bins", bins, "octahedral bins per side of each ratio map", {"build"});
//       v.Knob("compare_truth", compare_truth, "compare with the simulated world's truth", {"report"});
//     }
//   };
//
// That one list drives everything a knob touches, so none can be left out of one of them:
//   - ApplySettings: parses the --set values into the fields (a value that does not parse is an
//     InvalidArgumentError naming the key and what it expects);
//   - AddKnobsToKey(key, knobs, "build"): every knob that changes the "build" stage enters its
//     StageKey (a knob missing from a key would be a silently stale cache);
//   - KnobsToJson: the values a run used, for summary.json;
//   - DescribeKnobs: name, type, default and help, for `relume process --list` and the tests
//     (every knob names at least one stage).
// Stage tags are the names the pipeline passes to AddKnobsToKey, plus "plan" (decides which
// frames or filters run; the keys follow from those), "report" (the summary only) and "none" (no
// effect on results, e.g. a thread count). A tag no AddKnobsToKey call uses would leave the knob
// out of every key: pipelines list their tags in PipelineEntry::stage_tags, and a test checks
// every knob against them.
// Field types: bool, int, std::int64_t, float, double, std::string.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "pipeline/stage_cache.h"

namespace relume::pipeline {

// Parses `text` as a knob's value; false when it does not parse (the field is left unchanged).
bool ParseKnobValue(std::string_view text, bool* value);
bool ParseKnobValue(std::string_view text, int* value);
bool ParseKnobValue(std::string_view text, std::int64_t* value);
bool ParseKnobValue(std::string_view text, float* value);  // finite only
bool ParseKnobValue(std::string_view text, double* value);
bool ParseKnobValue(std::string_view text, std::string* value);

// "a finite number", "an integer", "true or false", "text".
const char* KnobTypeExpectation(const bool*);
const char* KnobTypeExpectation(const int*);
const char* KnobTypeExpectation(const std::int64_t*);
const char* KnobTypeExpectation(const float*);
const char* KnobTypeExpectation(const double*);
const char* KnobTypeExpectation(const std::string*);

// One knob as `relume process --list --pipeline NAME` shows it.
struct KnobInfo {
  std::string name;
  std::string type;  // bool, int, number, text
  nlohmann::json default_value;
  std::string help;
  std::vector<std::string> stages;  // the stages whose results it changes ("report": none, only the summary)
};

namespace internal {

inline void AddToKey(StageKey& key, std::string_view name, bool v) {
  key.Add(name, v);
}
inline void AddToKey(StageKey& key, std::string_view name, int v) {
  key.Add(name, v);
}
inline void AddToKey(StageKey& key, std::string_view name, std::int64_t v) {
  key.Add(name, v);
}
inline void AddToKey(StageKey& key, std::string_view name, float v) {
  key.Add(name, static_cast<double>(v));
}
inline void AddToKey(StageKey& key, std::string_view name, double v) {
  key.Add(name, v);
}
inline void AddToKey(StageKey& key, std::string_view name, const std::string& v) {
  key.Add(name, v);
}

inline const char* TypeName(const bool*) {
  return "bool";
}
inline const char* TypeName(const int*) {
  return "int";
}
inline const char* TypeName(const std::int64_t*) {
  return "int";
}
inline const char* TypeName(const float*) {
  return "number";
}
inline const char* TypeName(const double*) {
  return "number";
}
inline const char* TypeName(const std::string*) {
  return "text";
}

[[noreturn]] void ThrowBadKnobValue(std::string_view name, std::string_view text, const char* expected);

struct Applier {
  const std::map<std::string, std::string>& settings;
  std::set<std::string>* used;
  template <typename T>
  void Knob(const char* name, T& field, const char* /*help*/, std::initializer_list<const char*> /*stages*/) {
    const auto it = settings.find(name);
    if (it == settings.end()) return;
    if (used != nullptr) used->insert(name);
    if (!ParseKnobValue(it->second, &field)) ThrowBadKnobValue(name, it->second, KnobTypeExpectation(&field));
  }
};

struct KeyAdder {
  StageKey& key;
  std::string_view stage;
  template <typename T>
  void Knob(const char* name, T& field, const char* /*help*/, std::initializer_list<const char*> stages) {
    for (const char* s : stages) {
      if (stage == s) {
        AddToKey(key, name, field);
        return;
      }
    }
  }
};

struct JsonWriter {
  nlohmann::json& json;
  template <typename T>
  void Knob(const char* name, T& field, const char* /*help*/, std::initializer_list<const char*> /*stages*/) {
    json[name] = field;
  }
};

struct Describer {
  std::vector<KnobInfo>& out;
  template <typename T>
  void Knob(const char* name, T& field, const char* help, std::initializer_list<const char*> stages) {
    out.push_back({name, TypeName(&field), nlohmann::json(field), help, {stages.begin(), stages.end()}});
  }
};

}  // namespace internal

// Sets the knobs named in `settings` (others keep their values); adds each name it used to
// *used. Throws InvalidArgumentError for a value that does not parse.
template <typename Knobs>
void ApplySettings(const std::map<std::string, std::string>& settings, Knobs& knobs, std::set<std::string>* used) {
  internal::Applier v{settings, used};
  knobs.VisitKnobs(v);
}

// Adds every knob that changes `stage` to `key`, by name.
// (VisitKnobs takes its fields by reference, so the readers below visit a copy.)
template <typename Knobs>
StageKey& AddKnobsToKey(StageKey& key, const Knobs& knobs, std::string_view stage) {
  internal::KeyAdder v{key, stage};
  Knobs copy = knobs;
  copy.VisitKnobs(v);
  return key;
}

template <typename Knobs>
nlohmann::json KnobsToJson(const Knobs& knobs) {
  nlohmann::json json = nlohmann::json::object();
  internal::JsonWriter v{json};
  Knobs copy = knobs;
  copy.VisitKnobs(v);
  return json;
}

// The knobs with their defaults (a default-constructed Knobs).
template <typename Knobs>
std::vector<KnobInfo> DescribeKnobs() {
  Knobs defaults;
  std::vector<KnobInfo> out;
  internal::Describer v{out};
  defaults.VisitKnobs(v);
  return out;
}

}  // namespace relume::pipeline

#pragma once
/// JSON visitor over a field list (fdv/core/field_list.h): the same keys and units as the YAML
/// (durations in ms under their `_ms` keys). Needs nlohmann_json (linked by fdv::io, and so by
/// the pipeline and the simulator).
///
///   nlohmann::json j = options_to_json(perception_options);   // {"compensation": {...}, ...}
/// Thread safety: a JsonWriter is used by one thread at a time; the functions share no state.
#include <nlohmann/json.hpp>

#include <string_view>
#include <vector>

#include "fdv/core/field_list.h"

namespace fdv {

class JsonWriter {
 public:
  explicit JsonWriter(nlohmann::json& out) : out_(out) {}

  template <class T>
  void operator()(const char* key, T& value, std::string_view = {}, std::string_view = {}) {
    if constexpr (field_list_detail::NamedEnum<T>) {
      out_[key] = field_text(value);
    } else if constexpr (requires { value.data(); value.size(); } && !std::is_same_v<T, std::string>) {
      nlohmann::json list = nlohmann::json::array();
      for (int i = 0; i < static_cast<int>(value.size()); ++i) list.push_back(double{value[i]});
      out_[key] = std::move(list);
    } else {
      out_[key] = value;
    }
  }
  void ms(const char* key, TimeNs& ns, std::string_view = {}) { out_[key] = ns_to_ms(ns); }
  template <class T, class... Check>
  void section(const char* key, T& sub, std::string_view = {}, const Check&...) {
    nlohmann::json inner = nlohmann::json::object();
    JsonWriter writer(inner);
    describe(writer, sub);
    out_[key] = std::move(inner);
  }
  template <class T>
  void list(const char* key, std::vector<T>& items, std::string_view = {}) {
    nlohmann::json list = nlohmann::json::array();
    for (auto& item : items) {
      nlohmann::json inner = nlohmann::json::object();
      JsonWriter writer(inner);
      describe(writer, item);
      list.push_back(std::move(inner));
    }
    out_[key] = std::move(list);
  }
  void removed(const char*, std::string_view) {}

 private:
  nlohmann::json& out_;
};

/// `options` as one JSON object.
template <class Options>
nlohmann::json options_to_json(Options options) {
  nlohmann::json out = nlohmann::json::object();
  JsonWriter writer(out);
  describe(writer, options);
  return out;
}

}  // namespace fdv

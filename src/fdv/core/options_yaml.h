#pragma once
/// YAML visitors over a field list (fdv/core/field_list.h): a strict loader and a writer. Used by
/// the pipeline's options (fdv/pipeline/options_yaml.h) and the simulator's scenarios.
///
///   YamlLoader load(root, file, {.validate = true});   // root: a map, or null/undefined = empty
///   describe(load, options);                          // fills what the file sets, keeps the rest
///   load.check_unknown();                             // a key nobody described -> InputError
///   YAML::Emitter out; out << YAML::BeginMap; YamlWriter w(out); describe(w, options); ...
///
/// Every error is InputError(file, "key <section>.<key>", reason): a wrong type ("'x' is not a
/// number"), an unknown key ("unknown key (known here: ...)"), a removed key (its reason), and,
/// with `validate`, a section whose validate() fails (where = the section; the reason names
/// durations by their YAML `_ms` keys). A yaml-cpp exception inside becomes one too.
/// Thread safety: a YamlLoader or YamlWriter is used by one thread at a time.
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/core/field_list.h"

namespace fdv {

struct YamlLoaderOptions {
  /// After each section, its validate() (or the check given to section()) must return "".
  bool validate = false;
  /// Longest list read by list(), refused before its items are built.
  std::size_t max_list_items = 64;
};

class YamlLoader {
 public:
  YamlLoader(const YAML::Node& node, const std::string& file, YamlLoaderOptions options = {},
             std::string prefix = {})
      : node_(node), file_(file), options_(options), prefix_(std::move(prefix)) {}

  template <class T>
  void operator()(const char* key, T& value, std::string_view = {}, std::string_view = {}) {
    if (const YAML::Node n = lookup(key)) guarded(path(key), [&] { read(n, value, path(key)); });
  }

  void ms(const char* key, TimeNs& ns, std::string_view = {}) {
    ms_keys_.insert(key);
    if (const YAML::Node n = lookup(key)) {
      guarded(path(key), [&] {
        const double v = number(n, path(key));
        if (std::abs(v) > 1e9) fail(path(key), "duration out of range");
        ns = static_cast<TimeNs>(std::llround(v * 1e6));
      });
    }
  }

  /// `check` (optional) replaces sub.validate() when validating: std::string(const T&).
  template <class T, class... Check>
  void section(const char* key, T& sub, std::string_view = {}, const Check&... check) {
    const YAML::Node n = lookup(key);
    if (!n || n.IsNull()) return;
    if (!n.IsMap()) fail(path(key), "expected a mapping of keys");
    YamlLoader inner(n, file_, options_, path(key) + ".");
    guarded(path(key), [&] {
      describe(inner, sub);
      inner.check_unknown();
    });
    if (!options_.validate) return;
    std::string why;
    if constexpr (sizeof...(Check) > 0) {
      why = (check(sub), ...);
    } else if constexpr (requires { sub.validate(); }) {
      why = sub.validate();
    }
    if (!why.empty()) fail(path(key), inner.with_yaml_names(why));
  }

  template <class T>
  void list(const char* key, std::vector<T>& items, std::string_view = {}) {
    const YAML::Node n = lookup(key);
    if (!n) return;
    if (!n.IsSequence()) fail(path(key), "expected a list");
    if (n.size() > options_.max_list_items)
      fail(path(key), fmt::format("{} items, at most {} are read", n.size(), options_.max_list_items));
    std::vector<T> out;
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::string item_key = fmt::format("{}[{}]", path(key), i);
      if (!n[i].IsMap()) fail(item_key, "expected a mapping of keys");
      T item = i < items.size() ? items[i] : T{};
      YamlLoader inner(n[i], file_, options_, item_key + ".");
      guarded(item_key, [&] {
        describe(inner, item);
        inner.check_unknown();
      });
      out.push_back(std::move(item));
    }
    items = std::move(out);
  }

  void removed(const char* key, std::string_view why) {
    if (lookup(key)) fail(path(key), std::string(why));
  }

  /// InputError for the first key of this map that no field, section or removed key named.
  void check_unknown() const {
    if (!node_.IsMap()) return;
    for (const auto& kv : node_) {
      if (!kv.first.IsScalar())
        fail(path("?"), "a key must be a plain name, not a list or map" + at(kv.first.Mark()));
      const std::string key = kv.first.Scalar();
      if (known_.count(key)) continue;
      std::string list;
      for (const auto& k : known_) list += (list.empty() ? "" : ", ") + k;
      fail(path(key), "unknown key (known here: " + list + ")");
    }
  }

  /// `why` (a validate() message, naming fields) with each `<stem>_ns` of a duration described
  /// here as its YAML key `<stem>_ms`.
  std::string with_yaml_names(std::string why) const {
    for (const std::string& key : ms_keys_)
      if (key.size() > 3 && key.ends_with("_ms")) rename_word(why, key.substr(0, key.size() - 3) + "_ns", key);
    return why;
  }

  [[noreturn]] void fail(const std::string& key, const std::string& reason) const {
    throw InputError(file_, key.empty() ? "" : "key " + key, reason);
  }
  std::string path(const std::string& key) const { return prefix_ + key; }

  double number(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(key, "expected a number");
    double v;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(key, "'" + n.Scalar() + "' is not a number");
    }
    if (!std::isfinite(v)) fail(key, "must be finite");
    return v;
  }

 private:
  YAML::Node lookup(const char* key) {
    known_.insert(key);
    if (!node_ || !node_.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
    return node_[key];
  }
  static std::string at(const YAML::Mark& m) {
    return m.is_null() ? "" : " (line " + std::to_string(m.line + 1) + ")";
  }
  /// Runs `f`; a yaml-cpp exception in it (a safety net: the readers check node kinds before
  /// converting) becomes InputError naming `key`.
  template <class F>
  void guarded(const std::string& key, F&& f) const {
    try {
      f();
    } catch (const YAML::Exception& e) {
      fail(key, yaml_reason(e) + at(e.mark));
    }
  }
  /// An integer as written ("12", "0x10"), or a number with no fraction ("1e3", "3.0").
  long long integer(const YAML::Node& n, const std::string& key, double limit) const {
    if (n.IsScalar()) {
      try {
        const long long v = n.as<long long>();
        if (std::abs(static_cast<double>(v)) <= limit) return v;
      } catch (const YAML::Exception&) {
      }
    }
    const double x = number(n, key);
    if (x != std::floor(x) || std::abs(x) > limit) fail(key, "'" + n.Scalar() + "' is not an integer");
    return static_cast<long long>(x);
  }

  void read(const YAML::Node& n, double& v, const std::string& key) const { v = number(n, key); }
  void read(const YAML::Node& n, int& v, const std::string& key) const {
    v = static_cast<int>(integer(n, key, 2e9));
  }
  void read(const YAML::Node& n, std::uint64_t& v, const std::string& key) const {
    if (!n.IsScalar()) fail(key, "expected a non-negative integer");
    try {
      v = n.as<std::uint64_t>();
    } catch (const YAML::Exception&) {
      fail(key, "'" + n.Scalar() + "' is not a non-negative integer");
    }
  }
  void read(const YAML::Node& n, bool& v, const std::string& key) const {
    if (!n.IsScalar()) fail(key, "expected true or false");
    try {
      v = n.as<bool>();
    } catch (const YAML::Exception&) {
      fail(key, "'" + n.Scalar() + "' is not true or false");
    }
  }
  void read(const YAML::Node& n, std::string& v, const std::string& key) const {
    if (!n.IsScalar()) fail(key, "expected a string");
    v = n.Scalar();
  }
  template <field_list_detail::NamedEnum E>
  void read(const YAML::Node& n, E& v, const std::string& key) const {
    std::string s;
    read(n, s, key);
    for (const E e : all_values(v))
      if (s == to_string(e)) {
        v = e;
        return;
      }
    fail(key, "'" + s + "' is not one of " + enum_choices(v));
  }
  void read_fixed(const YAML::Node& n, double* out, int size, const std::string& key) const {
    if (!n.IsSequence() || n.size() != static_cast<std::size_t>(size))
      fail(key, fmt::format("expected a list of {} numbers", size));
    for (int i = 0; i < size; ++i) out[i] = number(n[i], fmt::format("{}[{}]", key, i));
  }
  void read(const YAML::Node& n, Eigen::Vector3d& v, const std::string& key) const { read_fixed(n, v.data(), 3, key); }
  void read(const YAML::Node& n, Eigen::Vector2d& v, const std::string& key) const { read_fixed(n, v.data(), 2, key); }
  template <std::size_t N>
  void read(const YAML::Node& n, std::array<double, N>& v, const std::string& key) const {
    read_fixed(n, v.data(), static_cast<int>(N), key);
  }

  /// Replaces whole identifier words `from` by `to` in `s`.
  static void rename_word(std::string& s, const std::string& from, const std::string& to) {
    auto ident = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
    for (std::size_t pos = s.find(from); pos != std::string::npos; pos = s.find(from, pos)) {
      const std::size_t end = pos + from.size();
      if ((pos == 0 || !ident(s[pos - 1])) && (end == s.size() || !ident(s[end]))) {
        s.replace(pos, from.size(), to);
        pos += to.size();
      } else {
        pos = end;
      }
    }
  }

  const YAML::Node node_;
  const std::string& file_;
  YamlLoaderOptions options_;
  std::string prefix_;
  std::set<std::string> known_;
  std::set<std::string> ms_keys_;
};

/// Writes every field as a YAML map entry (the caller opens and closes the map): doubles in their
/// shortest round-trip form, so that loading the text gives the same values.
class YamlWriter {
 public:
  explicit YamlWriter(YAML::Emitter& out) : out_(out) {}

  template <class T>
  void operator()(const char* key, T& value, std::string_view = {}, std::string_view = {}) {
    out_ << YAML::Key << key << YAML::Value;
    write(value);
  }
  void ms(const char* key, TimeNs& ns, std::string_view = {}) {
    out_ << YAML::Key << key << YAML::Value << field_text(ns_to_ms(ns));
  }
  template <class T, class... Check>
  void section(const char* key, T& sub, std::string_view = {}, const Check&...) {
    out_ << YAML::Key << key << YAML::Value << YAML::BeginMap;
    describe(*this, sub);
    out_ << YAML::EndMap;
  }
  template <class T>
  void list(const char* key, std::vector<T>& items, std::string_view = {}) {
    out_ << YAML::Key << key << YAML::Value << YAML::BeginSeq;
    for (auto& item : items) {
      out_ << YAML::BeginMap;
      describe(*this, item);
      out_ << YAML::EndMap;
    }
    out_ << YAML::EndSeq;
  }
  void removed(const char*, std::string_view) {}

 private:
  template <class T>
  void write(const T& v) {
    if constexpr (std::is_same_v<T, int> || std::is_same_v<T, std::uint64_t> || std::is_same_v<T, bool>)
      out_ << v;
    else if constexpr (std::is_same_v<T, double> || std::is_same_v<T, std::string> ||
                       field_list_detail::NamedEnum<T>)
      out_ << field_text(v);
    else
      write_list(v.data(), static_cast<int>(v.size()));
  }
  void write_list(const double* v, int n) {
    out_ << YAML::Flow << YAML::BeginSeq;
    for (int i = 0; i < n; ++i) out_ << field_text(v[i]);
    out_ << YAML::EndSeq;
  }

  YAML::Emitter& out_;
};

/// The YAML text of `options` as one map (what a YamlLoader reads back to the same values).
template <class Options>
std::string options_to_yaml(Options options) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  YamlWriter writer(out);
  describe(writer, options);
  out << YAML::EndMap;
  return out.c_str();
}

}  // namespace fdv

#pragma once
/// Internal to src/fdv/io/config: strict reading of one YAML map of options into a struct.
///
///   Section s(root["tracking"], file, "tracking");
///   s.bind("gate_chi2", o.gate_chi2);              // double, int or bool field; or s.on(key,
///   setter) s.bind_ms("max_gap_ms", o.max_gap_ns);         // YAML milliseconds -> TimeNs
///   s.apply();                                     // unknown key -> InputError
///   s.check(o.validate());                         // invalid values -> InputError
///
/// Every error is InputError(file, "key <section>.<key>", reason), also for a yaml-cpp exception
/// inside a setter; a non-scalar key is "key <section>.?". An undefined or null node is
/// an empty section (defaults kept). Setters run in the file's order. Not for use outside the
/// config loaders: the public API is frontend_config.h and backend_config.h.
#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <string>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/core/time.h"

namespace fdv::config_internal {

class Section {
 public:
  Section(const YAML::Node& node, std::string file, std::string name)
      : node_(node), file_(std::move(file)), name_(std::move(name)) {
    if (node_ && !node_.IsNull() && !node_.IsMap())
      throw InputError(file_, where(name_), "expected a map of options");
  }
  using Setter = std::function<void(const YAML::Node&, const std::string& key)>;
  void on(const std::string& key, Setter setter) { setters_[key] = std::move(setter); }

  /// Field bindings for the common value kinds.
  void bind(const std::string& key, double& field) {
    on(key, [this, &field](const YAML::Node& n, const std::string& k) { field = number(n, k); });
  }
  void bind(const std::string& key, int& field) {
    on(key, [this, &field](const YAML::Node& n, const std::string& k) { field = int32(n, k); });
  }
  void bind(const std::string& key, bool& field) {
    on(key, [this, &field](const YAML::Node& n, const std::string& k) { field = boolean(n, k); });
  }
  /// `key` is in ms in YAML and must end in "_ms"; the field is in ns.
  void bind_ms(const std::string& key, TimeNs& field) {
    on(key, [this, &field](const YAML::Node& n, const std::string& k) { field = millis(n, k); });
  }

  /// When set, an unknown key's reason is "<what> (expected <every known key>)" instead of
  /// "unknown key" (for the top level, where a typo in a section name is likely).
  void list_keys_when_unknown(std::string what) { unknown_what_ = std::move(what); }

  void apply() const {
    if (!node_ || node_.IsNull()) return;
    for (const auto& kv : node_) {
      if (!kv.first.IsScalar())
        throw InputError(file_, where(path("?")),
                         "a key must be a plain name, not a list or map" + at(kv.first.Mark()));
      const std::string key = kv.first.Scalar();
      const auto it = setters_.find(key);
      if (it == setters_.end()) throw InputError(file_, where(path(key)), unknown_reason());
      try {
        it->second(kv.second, path(key));
      } catch (const YAML::Exception& e) {
        // A safety net: the value readers check node kinds before converting.
        throw InputError(file_, where(path(key)), yaml_reason(e) + at(e.mark));
      }
    }
  }

  double number(const YAML::Node& n, const std::string& key) const {
    double v;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(file_, where(key), "expected a number, got '" + scalar(n) + "'");
    }
    if (!std::isfinite(v)) throw InputError(file_, where(key), "expected a finite number");
    return v;
  }
  long long integer(const YAML::Node& n, const std::string& key) const {
    try {
      return n.as<long long>();
    } catch (const YAML::Exception&) {
      throw InputError(file_, where(key), "expected an integer, got '" + scalar(n) + "'");
    }
  }
  int int32(const YAML::Node& n, const std::string& key) const {
    const long long v = integer(n, key);
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
      throw InputError(file_, where(key), "integer out of range");
    return static_cast<int>(v);
  }
  bool boolean(const YAML::Node& n, const std::string& key) const {
    try {
      return n.as<bool>();
    } catch (const YAML::Exception&) {
      throw InputError(file_, where(key), "expected true or false, got '" + scalar(n) + "'");
    }
  }
  std::string text(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) throw InputError(file_, where(key), "expected a string");
    return n.Scalar();
  }
  TimeNs millis(const YAML::Node& n, const std::string& key) const {
    const double ms = number(n, key);
    if (std::abs(ms) > 1e9) throw InputError(file_, where(key), "duration out of range");
    return static_cast<TimeNs>(std::llround(ms * 1e6));
  }
  /// A flow or block list of exactly three finite numbers, e.g. `[0, 0, -9.81]`.
  Eigen::Vector3d vector3(const YAML::Node& n, const std::string& key) const {
    if (!n.IsSequence()) throw InputError(file_, where(key), "expected a list of 3 numbers");
    if (n.size() != 3)
      throw InputError(file_, where(key),
                       "expected a list of 3 numbers, got " + std::to_string(n.size()));
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = number(n[i], key + "[" + std::to_string(i) + "]");
    return v;
  }

  /// Throws when `why` (an options struct's validate() result) is not empty. validate() names
  /// fields, and durations by their *_ns names; those are renamed to the YAML *_ms keys here so
  /// the message names what the user wrote.
  void check(std::string why) const {
    if (why.empty()) return;
    for (const auto& kv : setters_) {
      const std::string& key = kv.first;
      if (key.size() > 3 && key.compare(key.size() - 3, 3, "_ms") == 0)
        rename_word(why, key.substr(0, key.size() - 3) + "_ns", key);
    }
    throw InputError(file_, where(name_), why);
  }

  const std::string& file() const { return file_; }
  const std::string& name() const { return name_; }

 private:
  std::string path(const std::string& key) const { return name_.empty() ? key : name_ + "." + key; }
  static std::string where(const std::string& key) { return key.empty() ? "" : "key " + key; }
  static std::string at(const YAML::Mark& m) {
    return m.is_null() ? "" : " (line " + std::to_string(m.line + 1) + ")";
  }
  static std::string scalar(const YAML::Node& n) {
    return n.IsScalar() ? n.Scalar() : "(not a scalar)";
  }
  std::string unknown_reason() const {
    if (unknown_what_.empty()) return "unknown key";
    std::string keys;
    for (const auto& kv : setters_) keys += (keys.empty() ? "" : ", ") + kv.first;
    return unknown_what_ + " (expected " + keys + ")";
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

  YAML::Node node_;
  std::string file_, name_;
  std::map<std::string, Setter> setters_;
  std::string unknown_what_;
};

}  // namespace fdv::config_internal

#pragma once
/// One field list per options struct: a `describe(visitor, options)` function template beside the
/// struct names every field once (YAML key, unit, one-line meaning); loading, writing (YAML,
/// JSON) and the docs' key tables are visitors over it, so they cannot disagree. Defaults are
/// those of the default-constructed struct.
///
///   template <class V>
///   void describe(V& v, TrackerOptions& o) {
///     v.section("filter", o.filter, "image-plane Kalman filter");
///     v("gate_chi2", o.gate_chi2, "-", "Mahalanobis gate on the 2-dof innovation");
///     v.ms("max_gap_ms", o.max_gap_ns, "a confirmed track is deleted after this gap");
///     v.removed("old_key", "moved to the top-level key new_key");
///   }
///   std::string table = options_markdown(TrackerOptions{});   // | key | default | unit | meaning |
///
/// The visitor protocol (every visitor implements all of it):
///   v(key, field, unit = "", meaning = "")  a value: double, int, bool, std::uint64_t,
///                                           std::string, Eigen::Vector2d/3d, std::array<double, N>,
///                                           or an enum E with to_string(E) and all_values(E)
///                                           (an std::array of every value) found by ADL
///   v.ms(key, TimeNs& field, meaning)       a duration held in ns, written in ms: `key` ends
///                                           in "_ms" (the field's name ends in "_ns")
///   v.section(key, sub, meaning)            a nested map, described by describe(v, sub)
///   v.list(key, std::vector<T>& items)      a list of maps, each described by describe(v, item)
///   v.removed(key, why)                     a key no longer read: loading it is an error saying why
/// Modules need no YAML or JSON library for this: the visitor is a template parameter. The
/// visitors are here (docs table), in fdv/core/options_yaml.h (load, write) and
/// fdv/core/options_json.h (write).
/// Thread safety: stateless templates; a visitor object is used by one thread at a time.
#include <fmt/format.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "fdv/core/time.h"

namespace fdv {

namespace field_list_detail {
template <class T>
concept NamedEnum = std::is_enum_v<T> && requires(T e) {
  { to_string(e) };
  { all_values(e) };
};
}  // namespace field_list_detail

/// "a, b, c": every text form of an enum field, for messages and docs.
template <field_list_detail::NamedEnum E>
std::string enum_choices(E e = E{}) {
  std::string out;
  for (const E v : all_values(e)) out += (out.empty() ? "" : ", ") + std::string(to_string(v));
  return out;
}

/// The text of a value as the YAML writer and the docs show it: shortest round-trip doubles,
/// true/false, enum names, and [x, y, z] for vectors.
inline std::string field_text(double v) { return fmt::format("{}", v); }
inline std::string field_text(int v) { return std::to_string(v); }
inline std::string field_text(std::uint64_t v) { return std::to_string(v); }
inline std::string field_text(bool v) { return v ? "true" : "false"; }
inline std::string field_text(const std::string& v) { return v; }
template <field_list_detail::NamedEnum E>
std::string field_text(E v) {
  return std::string(to_string(v));
}
template <class Vec>
  requires requires(const Vec& v) { v.size(); v[0] + 0.0; }
std::string field_text(const Vec& v) {
  std::string out = "[";
  for (int i = 0; i < static_cast<int>(v.size()); ++i) out += (i ? ", " : "") + field_text(double{v[i]});
  return out + "]";
}
/// A duration held in ns as its YAML value in ms.
inline double ns_to_ms(TimeNs ns) { return static_cast<double>(ns) / 1e6; }

/// Docs visitor: one Markdown row per field, nested keys dotted ("filter.measurement_sigma_px").
class MarkdownTableWriter {
 public:
  explicit MarkdownTableWriter(std::string prefix = {}) : prefix_(std::move(prefix)) {}

  template <class T>
  void operator()(const char* key, T& value, std::string_view unit = {}, std::string_view meaning = {}) {
    row(key, field_text(value), unit, meaning);
  }
  void ms(const char* key, TimeNs& ns, std::string_view meaning) {
    row(key, field_text(ns_to_ms(ns)), "ms", meaning);
  }
  template <class T>
  void section(const char* key, T& sub, std::string_view = {}) {
    MarkdownTableWriter inner(prefix_ + key + ".");
    describe(inner, sub);
    rows_ += inner.rows_;
  }
  template <class T>
  void list(const char* key, std::vector<T>&, std::string_view meaning = {}) {
    row(key, "[]", "", meaning);
  }
  void removed(const char*, std::string_view) {}

  /// The table, header included; a `|` in a meaning is escaped.
  std::string table() const {
    return "| key | default | unit | meaning |\n|---|---|---|---|\n" + rows_;
  }

 private:
  void row(const char* key, const std::string& value, std::string_view unit, std::string_view meaning) {
    std::string text(meaning);
    for (std::size_t p = text.find('|'); p != std::string::npos; p = text.find('|', p + 2))
      text.replace(p, 1, "\\|");
    rows_ += fmt::format("| `{}{}` | {} | {} | {} |\n", prefix_, key, value, unit.empty() ? "-" : unit, text);
  }
  std::string prefix_;
  std::string rows_;
};

/// The docs table of every key of `options` (pass a default-constructed struct for the defaults).
template <class Options>
std::string options_markdown(Options options) {
  MarkdownTableWriter writer;
  describe(writer, options);
  return writer.table();
}

}  // namespace fdv

#pragma once
/// The one gate every configuration-like file (calibration, `fdv run --config` options,
/// `fdv simulate --config` scenario) passes before a parser sees it: a size bound, and YAML
/// syntax errors turned into InputError naming the file and the line.
///
///   const std::string text = read_config_file(path);           // size-checked
///   const YAML::Node root = parse_config_yaml(text, path);      // InputError on bad syntax
///   return yaml_errors_as_input_errors(path, [&] { return read_options(root, path); });
///
/// Nesting depth is bounded by the parsers themselves: yaml-cpp 0.7.0 throws DeepRecursion past
/// 500 levels (about 498 nested `[`), tinyxml2 9.0.0 fails past 100 element levels; both
/// recurse only that deep, so no own pre-scan is needed. docs/FORMATS.md, "Bad input".
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <string_view>

#include "fdv/core/error.h"

namespace fdv {

/// Largest calibration, options or scenario file accepted [bytes]. Real ones are a few KB;
/// the bound keeps a hostile file from being read whole and handed to a parser.
inline constexpr std::size_t kMaxConfigFileBytes = std::size_t{1} << 20;

/// InputError(name, "", reason) when `text` is longer than kMaxConfigFileBytes.
inline void check_config_text(std::string_view text, const std::string& name) {
  if (text.size() > kMaxConfigFileBytes)
    throw InputError(name, "",
                     "larger than " + std::to_string(kMaxConfigFileBytes) +
                         " bytes: not a configuration file");
}

/// InputError(path, "", why) when `path` exists but is not a regular file: opening a FIFO blocks
/// until a writer comes, a device never ends, and a folder is no file. Every reader of a named
/// file checks this before opening it. Returns `path`.
inline const std::string& check_regular_file(const std::string& path) {
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
    throw InputError(path, "",
                     std::filesystem::is_directory(status) ? "is a folder, not a file"
                                                           : "not a regular file (a FIFO or a device cannot be read)");
  return path;
}

/// The whole file as text. InputError when it cannot be read, is not a regular file, or is longer
/// than kMaxConfigFileBytes (at most that many bytes plus one are read).
inline std::string read_config_file(const std::string& path) {
  std::ifstream in(check_regular_file(path), std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open the file");
  std::string text(kMaxConfigFileBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (in.bad()) throw InputError(path, "", "cannot read the file");
  text.resize(static_cast<std::size_t>(in.gcount()));
  check_config_text(text, path);
  return text;
}

/// "line L, column C" of a yaml-cpp mark (1-based), or "" when the mark is unset.
inline std::string yaml_position(const YAML::Mark& mark) {
  if (mark.is_null() || mark.line < 0) return "";
  return "line " + std::to_string(mark.line + 1) + ", column " + std::to_string(mark.column + 1);
}

/// A yaml-cpp message with its control and non-ASCII bytes as \xNN: it may quote the offending
/// byte of the file (e.g. "unknown escape character: " and a NUL).
inline std::string yaml_reason(const YAML::Exception& e) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (const char ch : e.msg) {
    const auto c = static_cast<unsigned char>(ch);
    if (c >= 0x20 && c < 0x7f) {
      out += ch;
    } else {
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  return out;
}

/// InputError(name, "line L, column C", "duplicate key 'k' ...") for the first key a mapping in
/// `node` repeats. yaml-cpp keeps every pair of a mapping and node[key] finds the first, so a
/// repeated key would silently lose its later value. A node reached again through an alias is
/// walked once (`walked`: the positions of the collections seen), so the walk is as long as the text.
inline void check_no_duplicate_keys(const YAML::Node& node, const std::string& name, std::set<int>& walked) {
  if (!node.IsMap() && !node.IsSequence()) return;
  if (!walked.insert(node.Mark().pos).second) return;
  if (node.IsSequence()) {
    for (const YAML::Node& item : node) check_no_duplicate_keys(item, name, walked);
    return;
  }
  std::map<std::string, YAML::Mark> keys;
  for (const auto& pair : node) {
    if (pair.first.IsScalar()) {
      const auto [first, inserted] = keys.emplace(pair.first.Scalar(), pair.first.Mark());
      if (!inserted)
        throw InputError(name, yaml_position(pair.first.Mark()),
                         "duplicate key '" + pair.first.Scalar() + "' (first at " + yaml_position(first->second) + ")");
    }
    check_no_duplicate_keys(pair.second, name, walked);
  }
}

/// Parses YAML text after check_config_text. Any yaml-cpp error, and a key repeated in a mapping,
/// becomes InputError(name, "line L, column C", reason).
inline YAML::Node parse_config_yaml(std::string_view text, const std::string& name) {
  check_config_text(text, name);
  YAML::Node root;
  try {
    root = YAML::Load(std::string(text));
  } catch (const YAML::DeepRecursion& e) {
    throw InputError(name, yaml_position(e.mark), "nested deeper than the YAML parser's limit");
  } catch (const YAML::Exception& e) {
    throw InputError(name, yaml_position(e.mark), yaml_reason(e));
  }
  std::set<int> walked;
  check_no_duplicate_keys(root, name, walked);
  return root;
}

/// read(), with a yaml-cpp error thrown by it turned into InputError(name, "line L, column C",
/// reason): the safety net behind readers that check node kinds before converting.
template <class Read>
auto yaml_errors_as_input_errors(const std::string& name, const Read& read) -> decltype(read()) {
  try {
    return read();
  } catch (const YAML::Exception& e) {
    throw InputError(name, yaml_position(e.mark), yaml_reason(e));
  }
}

}  // namespace fdv

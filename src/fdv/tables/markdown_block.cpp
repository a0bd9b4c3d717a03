#include "fdv/tables/markdown_block.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "fdv/core/error.h"

namespace fdv {

std::string replace_marked_block(const std::string& document, const std::string& name,
                                 const std::string& content, const std::string& source) {
  const std::string begin = "<!-- " + name + ":begin -->", end = "<!-- " + name + ":end -->";
  std::string body = content;
  if (!body.empty() && body.back() != '\n') body += '\n';
  const std::string block = begin + "\n" + body + end;
  const auto b = document.find(begin), e = document.find(end);
  auto fail = [&](const std::string& why) {
    throw ConfigError(source + ": block '" + name + "': " + why + " (expected one " + begin +
                      " ... " + end + ")");
  };
  if (b == std::string::npos && e == std::string::npos) {
    std::string out = document;
    if (!out.empty() && out.back() != '\n') out += '\n';
    if (!out.empty()) out += '\n';
    return out + block + "\n";
  }
  if (b == std::string::npos) fail("end marker without a begin marker");
  if (e == std::string::npos) fail("begin marker without an end marker");
  if (e < b) fail("end marker before the begin marker");
  if (document.find(begin, b + 1) != std::string::npos ||
      document.find(end, e + 1) != std::string::npos)
    fail("markers appear more than once");
  return document.substr(0, b) + block + document.substr(e + end.size());
}

void write_marked_block(const std::string& path, const std::string& name,
                        const std::string& content, const std::string& title) {
  namespace fs = std::filesystem;
  std::string document;
  if (fs::exists(path)) {
    std::ifstream in(path);
    if (!in) throw InputError(path, "", "cannot read");
    std::ostringstream s;
    s << in.rdbuf();
    document = s.str();
  } else {
    document = title + "\n";
  }
  const std::string out = replace_marked_block(document, name, content, path);
  const fs::path target(path);
  if (target.has_parent_path()) fs::create_directories(target.parent_path());
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    f << out;
    if (!f) throw InputError(tmp, "", "cannot write");
  }
  fs::rename(tmp, target);
}

}  // namespace fdv

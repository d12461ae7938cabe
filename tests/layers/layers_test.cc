// The include graph of the sources against the layering of docs/architecture.md. What matters most
// here is issue 19's rule: processing (pipeline/, processing/) reaches no simulator header, so
// ground truth can only come in through core/truth.h's SessionTruth, set by the caller.
//
// Each layer's library sources (not its tests, benchmarks, fuzzers or testing/ helpers) are
// followed through every #include "..." that names a file of the tree, transitively; the top-level
// folders reached must be among the layer's allowed ones. A failure prints the include chain.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace relume {
namespace {

namespace fs = std::filesystem;

bool IsLibrarySource(const std::string& relative) {
  const std::string ext = fs::path(relative).extension().string();
  if (ext != ".h" && ext != ".cc") return false;
  for (const char* suffix : {"_test.cc", "_benchmark.cc", "_fuzzer.cc"}) {
    if (relative.ends_with(suffix)) return false;
  }
  return relative.find("/testing/") == std::string::npos && relative.find("/testing_") == std::string::npos;
}

// The file named by a line `#include "FILE"` (spaces allowed around # and include), or "".
std::string QuotedInclude(const std::string& line) {
  std::size_t at = line.find_first_not_of(" \t");
  if (at == std::string::npos || line[at] != '#') return "";
  at = line.find_first_not_of(" \t", at + 1);
  if (at == std::string::npos || line.compare(at, 7, "include") != 0) return "";
  at = line.find_first_not_of(" \t", at + 7);
  if (at == std::string::npos || line[at] != '"') return "";
  const std::size_t end = line.find('"', at + 1);
  return end == std::string::npos ? "" : line.substr(at + 1, end - at - 1);
}

// For every file reached from `layer`'s library sources, the chain of includes that first reached it.
std::map<std::string, std::vector<std::string>> Reached(const fs::path& root, const std::string& layer) {
  std::map<std::string, std::vector<std::string>> chain;
  std::vector<std::string> pending;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(root / layer)) {
    const std::string relative = fs::relative(e.path(), root).generic_string();
    if (e.is_regular_file() && IsLibrarySource(relative) && !chain.contains(relative)) {
      chain[relative] = {relative};
      pending.push_back(relative);
    }
  }
  while (!pending.empty()) {
    const std::string file = pending.back();
    pending.pop_back();
    std::ifstream in(root / file);
    std::string line;
    while (std::getline(in, line)) {
      const std::string header = QuotedInclude(line);
      if (header.empty() || chain.contains(header) || !fs::exists(root / header)) continue;  // system or generated
      chain[header] = chain[file];
      chain[header].push_back(header);
      pending.push_back(header);
    }
  }
  return chain;
}

std::string TopFolder(const std::string& relative) {
  return relative.substr(0, relative.find('/'));
}

// The files of `layer` that reach a folder outside `allowed`, one line each with its chain.
std::vector<std::string> Violations(const fs::path& root, const std::string& layer,
                                    const std::set<std::string>& allowed) {
  std::vector<std::string> out;
  for (const auto& [file, chain] : Reached(root, layer)) {
    if (allowed.contains(TopFolder(file))) continue;
    std::string text;
    for (const std::string& step : chain) text += (text.empty() ? "" : " -> ") + step;
    out.push_back(text);
  }
  return out;
}

std::string Join(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += "  " + line + "\n";
  return text;
}

struct Layer {
  std::string name;
  std::set<std::string> allowed;
};

TEST(LayersTest, EachLayerReachesOnlyTheLayersBelowIt) {
  const fs::path root(RELUME_SOURCE_DIR);
  const std::vector<Layer> layers = {
      {"core", {"core"}},
      {"calibration", {"core", "calibration"}},
      {"processing", {"core", "processing"}},
      {"capture", {"core", "drivers", "capture"}},
      // The pipelines: never the simulator (sim/) nor the rig files that hold its world (rig/).
      {"pipeline", {"core", "calibration", "capture", "drivers", "processing", "pipeline"}},
  };
  for (const Layer& layer : layers) {
    ASSERT_TRUE(fs::is_directory(root / layer.name)) << (root / layer.name);
    const std::vector<std::string> bad = Violations(root, layer.name, layer.allowed);
    EXPECT_TRUE(bad.empty()) << layer.name << "/ reaches a layer it must not:\n" << Join(bad);
  }
}

TEST(LayersTest, TheCheckFindsAnIncludeChainIntoTheSimulator) {
  const fs::path root = fs::path(testing::TempDir()) / "relume-layers-test";
  fs::remove_all(root);
  fs::create_directories(root / "pipeline");
  fs::create_directories(root / "core");
  fs::create_directories(root / "sim" / "world");
  std::ofstream(root / "pipeline" / "a.cc") << "#include <vector>\n#include \"core/b.h\"\n";
  std::ofstream(root / "pipeline" / "a_test.cc") << "#include \"sim/world/world.h\"\n";  // tests may
  std::ofstream(root / "core" / "b.h") << "#pragma once\n  #  include \"sim/world/world.h\"\n";
  std::ofstream(root / "sim" / "world" / "world.h") << "#pragma once\n";
  const std::vector<std::string> bad = Violations(root, "pipeline", {"core", "pipeline"});
  ASSERT_EQ(bad.size(), 1u) << Join(bad);
  EXPECT_EQ(bad[0], "pipeline/a.cc -> core/b.h -> sim/world/world.h");
  EXPECT_TRUE(Violations(root, "pipeline", {"core", "pipeline", "sim"}).empty());
  fs::remove_all(root);
}

}  // namespace
}  // namespace relume

// The readers' compact YAML tree (src/core/io/yaml_tree.h): the same document and the same conversions as
// yaml-cpp's YAML::Load, aliases shared and bounded, marks for messages, and memory a small multiple of the text.
#include <gtest/gtest.h>

#include <malloc.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "../../src/core/io/yaml_tree.h"
#include "../../src/core/io/yaml_util.h"
#include "insitu_calibration/io/calibration_file.h"
#include "insitu_calibration/io/correspondence_file.h"

namespace yu = insitu_calibration::yaml_util;
namespace fs = std::filesystem;

namespace
{
yu::YamlTree parsed(const std::string& text, size_t max_nodes = 1000000)
{
  auto tree = yu::parseYamlTree(text, max_nodes, "test.yaml");
  EXPECT_TRUE(tree) << (tree ? "" : tree.error().describe());
  if (tree)
    return std::move(*tree);
  auto empty = yu::parseYamlTree("", 10, "empty.yaml");
  return std::move(*empty);
}

// Compares a view with yaml-cpp's node for the same text, recursively; returns the first difference.
std::string difference(const yu::YamlNode& mine, const YAML::Node& theirs, const std::string& at)
{
  if (mine.IsNull() != theirs.IsNull() || mine.IsScalar() != theirs.IsScalar() ||
      mine.IsSequence() != theirs.IsSequence() || mine.IsMap() != theirs.IsMap())
    return at + ": kind differs";
  if (mine.Scalar() != theirs.Scalar() || mine.size() != theirs.size())
    return at + ": scalar or size differs";
  if (mine.Mark().line != theirs.Mark().line || mine.Mark().column != theirs.Mark().column)
    return at + ": mark differs";
  if (mine.IsSequence())
    for (size_t i = 0; i < mine.size(); ++i)
      if (const std::string d = difference(mine[i], theirs[i], at + "[" + std::to_string(i) + "]"); !d.empty())
        return d;
  if (mine.IsMap())
  {
    auto other = theirs.begin();
    for (const auto& entry : mine)
    {
      const std::string key = at + "{" + entry.first.Scalar() + "}";
      std::string d = difference(entry.first, other->first, key + ".key");
      if (d.empty())
        d = difference(entry.second, other->second, key);
      if (!d.empty())
        return d;
      ++other;
    }
  }
  return "";
}
}  // namespace

TEST(YamlTree, NestedMapsSequencesAndScalars)
{
  const yu::YamlTree tree = parsed("name: lobby\nsize: [640, 480]\nnested:\n  - {a: 1, b: [x, y]}\n  - ~\nempty:\n");
  const yu::YamlNode doc = tree.root();
  ASSERT_TRUE(doc.IsMap());
  EXPECT_EQ(doc.size(), 4u);
  EXPECT_EQ(doc["name"].Scalar(), "lobby");
  EXPECT_EQ(doc["size"][1].as<int>(), 480);
  EXPECT_EQ(doc["nested"][0]["b"][1].as<std::string>(), "y");
  EXPECT_TRUE(doc["nested"][1].IsNull());
  EXPECT_TRUE(doc["empty"].IsNull());
  EXPECT_FALSE(doc["missing"]);
  EXPECT_FALSE(doc["size"][2]);
  EXPECT_FALSE(doc["missing"]["deeper"]);  // as yaml-cpp: undefined all the way down, no throw
  std::vector<std::string> keys;
  for (const auto& entry : doc)
    keys.push_back(entry.first.Scalar());
  EXPECT_EQ(keys, (std::vector<std::string>{"name", "size", "nested", "empty"}));
  int sum = 0;
  for (const auto& item : doc["size"])
    sum += item.as<int>();
  EXPECT_EQ(sum, 1120);
  EXPECT_TRUE(parsed("").root().IsNull());
  EXPECT_TRUE(parsed("# only a comment\n").root().IsNull());
}

TEST(YamlTree, AliasesShareTheAnchoredNode)
{
  const yu::YamlTree tree = parsed("a: &p [1, {k: v}]\nb: *p\nc: &s text\nd: [*s, *s]\n");
  const yu::YamlNode doc = tree.root();
  ASSERT_TRUE(doc["b"].IsSequence());
  EXPECT_EQ(doc["b"][1]["k"].Scalar(), "v");
  EXPECT_EQ(doc["d"][1].Scalar(), "text");
  EXPECT_EQ(doc["b"].Mark().line, doc["a"].Mark().line);  // the same node, not a copy
  const auto theirs = YAML::Load("a: &p [1, {k: v}]\nb: *p\nc: &s text\nd: [*s, *s]\n");
  EXPECT_EQ(difference(doc, theirs, "doc"), "");
}

TEST(YamlTree, SelfReferenceAndExpansionBeyondTheLimitAreRefused)
{
  for (const std::string cyclic : {"a: &x [*x]\n", "&x {k: *x}\n", "a: &x\n  - b: [1, *x]\n"})
  {
    const auto tree = yu::parseYamlTree(cyclic, 1000, "cyclic.yaml");
    ASSERT_FALSE(tree) << cyclic;
    EXPECT_NE(tree.error().message().find("aliases"), std::string::npos) << tree.error().describe();
  }
  // [1, 2, 3] is 4 nodes; its alias counts them again.
  EXPECT_TRUE(yu::parseYamlTree("[1, 2, 3]", 4, "t"));
  EXPECT_FALSE(yu::parseYamlTree("[1, 2, 3]", 3, "t"));
  EXPECT_TRUE(yu::parseYamlTree("a: &x [1, 2, 3]\nb: *x\n", 11, "t"));   // map 1, keys 2, [1,2,3] twice 8
  EXPECT_FALSE(yu::parseYamlTree("a: &x [1, 2, 3]\nb: *x\n", 10, "t"));  // the alias's expansion counts
  // A billion laughs: ten levels of ten aliases, 10^10 nodes from 400 bytes.
  std::string laughs = "l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]\n";
  for (int level = 1; level < 10; ++level)
  {
    const std::string prev = "*l" + std::to_string(level - 1);
    laughs += "l" + std::to_string(level) + ": &l" + std::to_string(level) + " [" + prev;
    for (int k = 1; k < 10; ++k)
      laughs += ", " + prev;
    laughs += "]\n";
  }
  const auto bomb = yu::parseYaml(laughs, "laughs.yaml");
  ASSERT_FALSE(bomb);
  EXPECT_NE(bomb.error().message().find("expands to more than"), std::string::npos) << bomb.error().describe();
  const auto bad = yu::parseYamlTree("a: [1, 2\n", 100, "bad.yaml");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message().find("not valid YAML"), std::string::npos) << bad.error().describe();
}

TEST(YamlTree, MarksAndYamlCppErrorsNameTheLine)
{
  const yu::YamlTree tree = parsed("a: 1\nb:\n  c: five\n  d: 5\n");
  const yu::YamlNode doc = tree.root();
  EXPECT_EQ(doc["b"]["c"].Mark().line, 2);  // 0-based, as yaml-cpp
  EXPECT_EQ(doc["b"]["c"].Mark().column, 5);
  try
  {
    (void)doc["b"]["c"].as<double>();
    ADD_FAILURE() << "converted 'five'";
  }
  catch (const YAML::BadConversion& e)
  {
    EXPECT_NE(std::string(e.what()).find("line 3, column 6"), std::string::npos) << e.what();
  }
  // A scalar where a map is due: yaml-cpp's BadSubscript, which `guarded` turns into a parse error.
  EXPECT_THROW((void)doc["b"]["d"]["x"], YAML::BadSubscript);
  const auto guarded = yu::guarded<int>("test.yaml", [&] { return doc["b"]["d"]["x"].as<int>(); });
  ASSERT_FALSE(guarded);
  EXPECT_NE(guarded.error().message().find("line 4, column 6"), std::string::npos) << guarded.error().describe();
  const auto calibration = insitu_calibration::parseCalibration("image_width: 640\ndivision_model: 5\n");
  EXPECT_FALSE(calibration);
  const auto lines = insitu_calibration::parseCorrespondences("image_width: 640\nimage_height: 480\nlines: [5]\n");
  ASSERT_FALSE(lines);
  EXPECT_NE(lines.error().message().find("lines[0]"), std::string::npos) << lines.error().describe();
}

TEST(YamlTree, MarksMatchYamlCppWhereEventsComeOutOfOrder)
{
  // A complex key whose value is missing: yaml-cpp reports that null after the next key, on an earlier line.
  for (const std::string text :
       {"m:\n  rows: 6\n? cols: 3\n  data: 1\nnext: [a,\n  b]\n", "-\n", "", "? [a, b]\n: c\n"})
  {
    const yu::YamlTree tree = parsed(text);
    EXPECT_EQ(difference(tree.root(), YAML::Load(text), "doc"), "") << text;
  }
}

TEST(YamlTree, ConversionsMatchYamlCpp)
{
  for (const std::string text :
       {"1",     "-1",   "+1",   "-0",  "0x10", "010", "1e3",        "1.5",      "-2.5e-3", ".inf", "-.Inf",
        "+.INF", ".nan", ".NaN", "abc", "1,5",  "1 ",  "4294967296", "1e400",    "9e18",    "yes",  "No",
        "TRUE",  "tRue", "True", "off", "ON",   "y",   "n",          "'quoted'", "\"1\"",   "''"})
  {
    const std::string doc = "v: " + text + "\n";
    const yu::YamlTree tree = parsed(doc);
    const yu::YamlNode mine = tree.root()["v"];
    const YAML::Node theirs = YAML::Load(doc)["v"];
    const double d_mine = mine.as<double>(-7.0), d_theirs = theirs.as<double>(-7.0);
    EXPECT_TRUE(d_mine == d_theirs || (std::isnan(d_mine) && std::isnan(d_theirs))) << text;
    EXPECT_EQ(mine.as<int>(-7), theirs.as<int>(-7)) << text;
    EXPECT_EQ(mine.as<size_t>(7), theirs.as<size_t>(7)) << text;
    EXPECT_EQ(mine.as<int>(2), theirs.as<int>(2)) << text;
    EXPECT_EQ(mine.as<bool>(false), theirs.as<bool>(false)) << text;
    EXPECT_EQ(mine.as<bool>(true), theirs.as<bool>(true)) << text;
    EXPECT_EQ(mine.as<std::string>(), theirs.as<std::string>()) << text;
  }
  const yu::YamlTree tree = parsed("n: ~\ns: [1]\n");
  EXPECT_EQ(tree.root()["n"].as<std::string>(), "null");  // as yaml-cpp
  EXPECT_THROW((void)tree.root()["s"].as<std::string>(), YAML::BadConversion);
  EXPECT_THROW((void)tree.root()["missing"].as<double>(), YAML::BadConversion);
  EXPECT_EQ(tree.root()["missing"].as<double>(3.0), 3.0);
}

TEST(YamlTree, TheProjectsFilesReadAsWithYamlCpp)
{
  // Every example and fuzz-corpus file: yaml-cpp's tree and ours agree node by node, or both refuse the text.
  size_t compared = 0;
  for (const std::string dir : {"config", "test/fuzz/corpus"})
    for (const auto& entry : fs::recursive_directory_iterator(std::string(INSITU_SOURCE_DIR) + "/" + dir))
    {
      if (!entry.is_regular_file() || entry.file_size() > (1 << 20))
        continue;
      std::ifstream in(entry.path(), std::ios::binary);
      const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      YAML::Node theirs;
      bool valid = true;
      try
      {
        theirs = YAML::Load(text);
      }
      catch (const YAML::Exception&)
      {
        valid = false;
      }
      const auto mine = yu::parseYamlTree(text, 2 * text.size() + 1024, entry.path().string());
      if (!valid)
      {
        EXPECT_FALSE(mine) << entry.path();
        continue;
      }
      if (!mine)  // refused only for its aliases' expansion
      {
        EXPECT_NE(mine.error().message().find("aliases"), std::string::npos) << mine.error().describe();
        continue;
      }
      EXPECT_EQ(difference(mine->root(), theirs, entry.path().filename().string()), "");
      ++compared;
    }
  EXPECT_GT(compared, 20u);
}

TEST(YamlTree, MemoryIsASmallMultipleOfTheText)
{
  // The densest documents: one node per 2 bytes (a flow list of digits) and per byte (a flow map of keys
  // without values, a key and a null each); and a realistic one, numbers of 8 characters.
  std::string digits = "[", keys = "{", numbers = "[";
  for (int i = 0; i < 500000; ++i)
  {
    digits += i ? ",1" : "1";
    keys += i ? ",a" : "a";
    numbers += (i ? ", " : "") + std::to_string(1000 + i % 9000) + ".567";
  }
  digits += "]";
  keys += "}";
  numbers += "]";
  for (const auto& [text, factor] : {std::pair<const std::string&, double>{digits, 8.0}, {keys, 16.0}, {numbers, 3.0}})
  {
    const struct mallinfo2 before = mallinfo2();
    const auto tree = yu::parseYamlTree(text, 2 * text.size() + 1024, "dense.yaml");
    ASSERT_TRUE(tree);
    const struct mallinfo2 after = mallinfo2();
    const double held = static_cast<double>((after.uordblks + after.hblkhd) - (before.uordblks + before.hblkhd));
    EXPECT_LE(static_cast<double>(tree->memoryBytes()), factor * text.size()) << text.substr(0, 20);
    EXPECT_LE(held, factor * text.size()) << text.substr(0, 20);
  }
}

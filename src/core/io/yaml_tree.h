// A compact, read-only YAML document for the file readers. yaml-cpp's own node tree (YAML::Load) costs a few
// hundred bytes per node (shared pointers, node_data, node_memory), 60-500 times a dense file's size; this tree is
// built from yaml-cpp's event parser into flat arrays, about 12 bytes per node, and an alias is stored as the
// index of its anchored node (never copied). YamlNode is a view with the subset of YAML::Node's read API that the
// readers use, with yaml-cpp's semantics: a missing key gives an undefined node, operator[] on a scalar throws
// YAML::BadSubscript, as<T>() throws YAML::TypedBadConversion<T> and converts exactly as yaml-cpp does (the
// readers' `guarded` turns those into parse errors). Internal to the core library.
#ifndef INSITU_CALIBRATION_SRC_CORE_IO_YAML_TREE_H
#define INSITU_CALIBRATION_SRC_CORE_IO_YAML_TREE_H

#include <cstdint>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <yaml-cpp/exceptions.h>
#include <yaml-cpp/mark.h>

#include "insitu_calibration/error.h"

namespace insitu_calibration
{
namespace yaml_util
{
enum class YamlKind : uint8_t
{
  kNull = 0,
  kScalar = 1,
  kSequence = 2,
  kMap = 3,
};

// The document's arrays. Node i (but a null, see kInlineNull): kind_pos[i] holds its kind (top 2 bits) and the byte
// position of its first token (for Mark()); data[i] is, for a scalar, the offset of its text in `chars` (a varint
// length, then the bytes) and, for a container, the offset in `children` of its child count followed by the children's
// node indices (a map's as key, value, key, value...). An alias is the anchored node's index in its parent's children.
struct YamlTreeData
{
  std::vector<uint32_t> kind_pos;
  std::vector<uint32_t> data;
  std::vector<uint32_t> children;
  std::string chars;
  std::vector<std::pair<uint32_t, uint32_t>> line_starts;  // (byte position, line), ascending: Mark() from a position
  uint32_t root = 0;

  static constexpr uint32_t kPosBits = 30;
  static constexpr uint32_t kPosMask = (uint32_t{1} << kPosBits) - 1;
  // A null (most often a map's missing value) has no entry in the arrays: its index is this bit and its position.
  static constexpr uint32_t kInlineNull = uint32_t{1} << 31;
  YamlKind kind(uint32_t i) const
  {
    return (i & kInlineNull) ? YamlKind::kNull : static_cast<YamlKind>(kind_pos[i] >> kPosBits);
  }
  uint32_t pos(uint32_t i) const { return (i & kInlineNull) ? (i & kPosMask) : (kind_pos[i] & kPosMask); }
  std::string_view scalar(uint32_t i) const;
  YAML::Mark mark(uint32_t i) const;
};

// yaml-cpp's convert<T>::decode for numbers (node/convert.h), on the scalar's text: the same stream, flags and
// special values, so that a reader accepts and refuses exactly what it did with YAML::Node::as<T>().
template <typename T>
bool decodeNumber(std::string_view text, T& out)
{
  static_assert(std::is_arithmetic<T>::value && !std::is_same<T, bool>::value, "numbers only");
  thread_local std::istringstream stream;  // constructing a stream (its locale) costs more than the parse
  stream.clear();
  stream.flags(std::ios::skipws | std::ios::dec);
  stream.str(std::string(text));
  stream.unsetf(std::ios::dec);
  if (stream.peek() == '-' && std::is_unsigned<T>::value)
    return false;
  using Read = std::conditional_t<sizeof(T) == 1, int, T>;
  Read value{};
  if ((stream >> std::noskipws >> value) && (stream >> std::ws).eof())
  {
    if (sizeof(T) == 1 && (value < std::numeric_limits<T>::min() || value > std::numeric_limits<T>::max()))
      return false;
    out = static_cast<T>(value);
    return true;
  }
  if constexpr (std::numeric_limits<T>::has_infinity)
  {
    if (text == ".inf" || text == ".Inf" || text == ".INF" || text == "+.inf" || text == "+.Inf" || text == "+.INF")
      return out = std::numeric_limits<T>::infinity(), true;
    if (text == "-.inf" || text == "-.Inf" || text == "-.INF")
      return out = -std::numeric_limits<T>::infinity(), true;
  }
  if constexpr (std::numeric_limits<T>::has_quiet_NaN)
    if (text == ".nan" || text == ".NaN" || text == ".NAN")
      return out = std::numeric_limits<T>::quiet_NaN(), true;
  return false;
}

// yaml-cpp's convert<bool>::decode: true/yes/on/y and false/no/off/n, in lower, upper or capitalised case.
bool decodeBool(std::string_view text, bool& out);

struct YamlEntry;
class YamlIterator;

// A node of a YamlTree, or an undefined node (a missing key or index). Valid while its tree lives.
class YamlNode
{
public:
  YamlNode() = default;
  YamlNode(const YamlTreeData* tree, uint32_t index) : tree_(tree), index_(index) {}

  bool IsDefined() const { return tree_ != nullptr; }
  explicit operator bool() const { return IsDefined(); }
  bool operator!() const { return !IsDefined(); }
  bool IsNull() const { return tree_ && tree_->kind(index_) == YamlKind::kNull; }
  bool IsScalar() const { return tree_ && tree_->kind(index_) == YamlKind::kScalar; }
  bool IsSequence() const { return tree_ && tree_->kind(index_) == YamlKind::kSequence; }
  bool IsMap() const { return tree_ && tree_->kind(index_) == YamlKind::kMap; }

  // Entries of a map, items of a sequence, 0 otherwise.
  size_t size() const;
  // The item of a sequence (undefined past its end), the value of a map's key that reads as this number.
  YamlNode operator[](size_t index) const;
  template <typename Integer, typename = std::enable_if_t<std::is_integral<Integer>::value>>
  YamlNode operator[](Integer index) const
  {
    if (index >= 0)
      return (*this)[static_cast<size_t>(index)];
    if (IsScalar())
      throw YAML::BadSubscript(Mark(), index);
    return YamlNode();
  }
  // The value of a map's first entry whose key is this scalar; undefined if none (or not a map).
  YamlNode operator[](const std::string& key) const { return at(key, key); }
  YamlNode operator[](const char* key) const { return at(key, key); }

  // The scalar's text; empty for any other node, as yaml-cpp.
  std::string Scalar() const { return IsScalar() ? std::string(tree_->scalar(index_)) : std::string(); }
  std::string_view scalarView() const { return IsScalar() ? tree_->scalar(index_) : std::string_view(); }
  YAML::Mark Mark() const { return tree_ ? tree_->mark(index_) : YAML::Mark::null_mark(); }

  template <typename T>
  T as() const
  {
    T value{};
    if (!decode(value))
      throw YAML::TypedBadConversion<T>(Mark());
    return value;
  }
  template <typename T, typename S>
  T as(const S& fallback) const
  {
    T value{};
    return decode(value) ? value : T(fallback);
  }

  YamlIterator begin() const;
  YamlIterator end() const;

private:
  template <typename Key>
  YamlNode at(std::string_view key, const Key& key_for_error) const
  {
    if (IsScalar())
      throw YAML::BadSubscript(Mark(), key_for_error);
    return find(key);
  }
  YamlNode find(std::string_view key) const;
  bool decode(std::string& out) const;
  bool decode(bool& out) const { return IsScalar() && decodeBool(scalarView(), out); }
  template <typename T>
  bool decode(T& out) const
  {
    return IsScalar() && decodeNumber(scalarView(), out);
  }

  const YamlTreeData* tree_ = nullptr;
  uint32_t index_ = 0;
};

// What iterating a node yields, as yaml-cpp's iterator_value: a sequence's item is the node itself, a map's entry
// is .first (the key) and .second (the value).
struct YamlEntry : YamlNode
{
  YamlNode first;
  YamlNode second;
};

class YamlIterator
{
public:
  YamlIterator(const YamlTreeData* tree, const uint32_t* at, bool map) : tree_(tree), at_(at), map_(map) {}
  YamlEntry operator*() const;
  YamlIterator& operator++()
  {
    at_ += map_ ? 2 : 1;
    return *this;
  }
  bool operator!=(const YamlIterator& other) const { return at_ != other.at_; }
  bool operator==(const YamlIterator& other) const { return at_ == other.at_; }

private:
  const YamlTreeData* tree_;
  const uint32_t* at_;
  bool map_;
};

// A parsed document; its nodes are views into it, so it must outlive them (moving it keeps them valid).
class YamlTree
{
public:
  YamlNode root() const { return YamlNode(data_.get(), data_->root); }
  // Bytes the tree holds (capacities of its arrays), for the memory bound's test.
  size_t memoryBytes() const;

private:
  friend Expected<YamlTree> parseYamlTree(const std::string&, size_t, const std::string&);
  std::unique_ptr<YamlTreeData> data_ = std::make_unique<YamlTreeData>();
};

// Parses the first document of `text` (an empty text is a null document). Refused: invalid YAML (with yaml-cpp's
// message), and a document that expands to more than max_nodes nodes when every alias is written out (a "billion
// laughs"), or whose anchor is used inside itself; either would let a small file make a reader's work unbounded.
Expected<YamlTree> parseYamlTree(const std::string& text, size_t max_nodes, const std::string& source);

}  // namespace yaml_util
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SRC_CORE_IO_YAML_TREE_H

#include "yaml_tree.h"

#include <algorithm>
#include <cctype>
#include <istream>
#include <streambuf>

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

namespace insitu_calibration
{
namespace yaml_util
{
namespace
{
// Thrown by the builder to stop the parser at once: the document expands past its limit or contains itself.
struct ExpansionRefused
{};

uint32_t checkedIndex(size_t value)
{
  if (value >= YamlTreeData::kInlineNull)
    throw std::bad_alloc();  // more nodes than an index holds: `guarded` reports it as too large
  return static_cast<uint32_t>(value);
}

// Builds a YamlTreeData from the parser's events. Open containers keep their children's indices on one stack
// (`pending_`) until they end, when the children are appended to the tree's `children` in one block. `expanded_`
// counts the nodes of the document with every alias written out, checked against the limit as the events come.
class TreeBuilder : public YAML::EventHandler
{
public:
  // Reserves what a document of text_bytes can need (a node per 2 bytes, with a null a child per byte): untouched
  // reserve costs no memory, while growing by doubling would leave the old blocks resident in the heap.
  TreeBuilder(YamlTreeData& tree, size_t max_nodes, size_t text_bytes) : tree_(tree), max_nodes_(max_nodes)
  {
    tree_.kind_pos.reserve(text_bytes / 2 + 16);
    tree_.data.reserve(text_bytes / 2 + 16);
    tree_.chars.reserve(text_bytes + 16);
    tree_.children.reserve(text_bytes + 16);
    pending_.reserve(text_bytes + 16);
  }

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t anchor) override
  {
    noteLine(mark);
    const uint32_t node =
        YamlTreeData::kInlineNull | (static_cast<uint32_t>(std::max(mark.pos, 0)) & YamlTreeData::kPosMask);
    setAnchor(anchor, node, 1);
    attach(node, 1);
  }
  void OnAlias(const YAML::Mark&, YAML::anchor_t anchor) override
  {
    if (anchor == 0 || anchor > anchors_.size() || anchors_[anchor - 1].second == 0)
      throw ExpansionRefused{};  // an anchor used inside its own node: an infinite document
    attach(anchors_[anchor - 1].first, anchors_[anchor - 1].second);
  }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor, const std::string& value) override
  {
    const uint32_t node = addNode(YamlKind::kScalar, mark);
    tree_.data[node] = checkedIndex(tree_.chars.size());
    for (size_t n = value.size(); true; n >>= 7)  // varint length: 7 bits a byte, low bits first
    {
      tree_.chars.push_back(static_cast<char>((n & 0x7f) | (n >= 0x80 ? 0x80 : 0)));
      if (n < 0x80)
        break;
    }
    tree_.chars += value;
    setAnchor(anchor, node, 1);
    attach(node, 1);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor,
                       YAML::EmitterStyle::value) override
  {
    open(YamlKind::kSequence, mark, anchor);
  }
  void OnSequenceEnd() override { close(); }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t anchor, YAML::EmitterStyle::value) override
  {
    open(YamlKind::kMap, mark, anchor);
  }
  void OnMapEnd() override { close(); }

  bool hasRoot() const { return has_root_; }

private:
  struct Open
  {
    uint32_t node;
    size_t first_pending;
    uint64_t weight;  // nodes of its expansion so far (itself and its closed children)
    YAML::anchor_t anchor;
  };

  uint32_t addNode(YamlKind kind, const YAML::Mark& mark)
  {
    const uint32_t index = checkedIndex(tree_.kind_pos.size());
    const uint32_t pos = static_cast<uint32_t>(std::max(mark.pos, 0)) & YamlTreeData::kPosMask;
    tree_.kind_pos.push_back((static_cast<uint32_t>(kind) << YamlTreeData::kPosBits) | pos);
    tree_.data.push_back(0);  // a scalar's text or a container's children, set by the caller
    noteLine(mark);
    return index;
  }

  // Line numbers: one entry per line on which a node starts, so that Mark() can be recomputed from a position.
  // Events come in the text's order except a few (the null of a complex key's missing value comes after the
  // value's key), so a line seen late is inserted where it belongs.
  void noteLine(const YAML::Mark& mark)
  {
    if (mark.pos < 0 || mark.line < 0 || mark.column < 0 || mark.column > mark.pos)
      return;
    auto& starts = tree_.line_starts;
    const std::pair<uint32_t, uint32_t> line(static_cast<uint32_t>(mark.pos - mark.column), mark.line);
    if (starts.empty() || line.first > starts.back().first)
      starts.push_back(line);
    else if (const auto at = std::lower_bound(starts.begin(), starts.end(), line,
                                              [](const auto& a, const auto& b) { return a.first < b.first; });
             at == starts.end() || at->first != line.first)
      starts.insert(at, line);
  }

  void setAnchor(YAML::anchor_t anchor, uint32_t node, uint64_t weight)
  {
    if (anchor == 0)
      return;
    if (anchor > anchors_.size())
      anchors_.resize(anchor, {0, 0});
    anchors_[anchor - 1] = {node, weight};
  }

  void attach(uint32_t node, uint64_t weight)
  {
    expanded_ += weight;
    if (expanded_ > max_nodes_)
      throw ExpansionRefused{};
    if (open_.empty())
    {
      tree_.root = node;
      has_root_ = true;
      return;
    }
    pending_.push_back(node);
    open_.back().weight += weight;
  }

  void open(YamlKind kind, const YAML::Mark& mark, YAML::anchor_t anchor)
  {
    const uint32_t node = addNode(kind, mark);
    setAnchor(anchor, node, 0);  // weight 0: open, an alias to it now would be a cycle
    if (++expanded_ > max_nodes_)
      throw ExpansionRefused{};
    open_.push_back({node, pending_.size(), 1, anchor});
  }

  void close()
  {
    const Open o = open_.back();
    open_.pop_back();
    tree_.data[o.node] = checkedIndex(tree_.children.size());
    tree_.children.push_back(checkedIndex(pending_.size() - o.first_pending));
    tree_.children.insert(tree_.children.end(), pending_.begin() + static_cast<std::ptrdiff_t>(o.first_pending),
                          pending_.end());
    pending_.resize(o.first_pending);
    setAnchor(o.anchor, o.node, o.weight);
    expanded_ -= o.weight;  // counted already, node by node; attach() adds it back as one
    attach(o.node, o.weight);
  }

  YamlTreeData& tree_;
  const size_t max_nodes_;
  std::vector<Open> open_;
  std::vector<uint32_t> pending_;
  std::vector<std::pair<uint32_t, uint64_t>> anchors_;  // anchor id - 1 -> (node, weight; 0 while open)
  uint64_t expanded_ = 0;
  bool has_root_ = false;
};

// An input stream over the caller's text, so that the parse does not hold a second copy of the file.
class TextBuffer : public std::streambuf
{
public:
  explicit TextBuffer(const std::string& text)
  {
    char* begin = const_cast<char*>(text.data());  // only read: std::streambuf's get area is char*
    setg(begin, begin, begin + text.size());
  }
};

// Gives back the arrays' growth reserve (up to half of each): the tree may live as long as its reader.
void shrink(YamlTreeData& tree)
{
  tree.kind_pos.shrink_to_fit();
  tree.data.shrink_to_fit();
  tree.children.shrink_to_fit();
  tree.chars.shrink_to_fit();
  tree.line_starts.shrink_to_fit();
}

template <typename T>
size_t capacityBytes(const std::vector<T>& v)
{
  return v.capacity() * sizeof(T);
}
}  // namespace

std::string_view YamlTreeData::scalar(uint32_t i) const
{
  size_t at = data[i];
  size_t length = 0;
  for (int shift = 0;; shift += 7)
  {
    const auto byte = static_cast<unsigned char>(chars[at++]);
    length |= static_cast<size_t>(byte & 0x7f) << shift;
    if (!(byte & 0x80))
      break;
  }
  return std::string_view(chars.data() + at, length);
}

YAML::Mark YamlTreeData::mark(uint32_t i) const
{
  if (kind_pos.empty() && line_starts.empty())
    return YAML::Mark::null_mark();  // an empty document, as yaml-cpp's
  const uint32_t p = pos(i);
  auto line = std::upper_bound(line_starts.begin(), line_starts.end(), p,
                               [](uint32_t value, const std::pair<uint32_t, uint32_t>& s) { return value < s.first; });
  YAML::Mark m;
  m.pos = static_cast<int>(p);
  if (line == line_starts.begin())
    return m;
  --line;
  m.line = static_cast<int>(line->second);
  m.column = static_cast<int>(p - line->first);
  return m;
}

bool decodeBool(std::string_view text, bool& out)
{
  // convert<bool>::decode (yaml-cpp src/convert.cpp): the names in lower case, upper case or capitalised.
  static const char* const kNames[][2] = {{"y", "n"}, {"yes", "no"}, {"true", "false"}, {"on", "off"}};
  const auto flexible = [](std::string_view s) {
    if (s.empty())
      return true;
    const bool upper_first = std::isupper(static_cast<unsigned char>(s[0])) != 0;
    bool all_lower = true, all_upper = true;
    for (size_t k = 1; k < s.size(); ++k)
    {
      all_lower = all_lower && std::islower(static_cast<unsigned char>(s[k]));
      all_upper = all_upper && std::isupper(static_cast<unsigned char>(s[k]));
    }
    return all_lower || (upper_first && all_upper);
  };
  if (!flexible(text))
    return false;
  std::string lower(text);
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const auto& name : kNames)
    for (int truth = 0; truth < 2; ++truth)
      if (lower == name[truth])
        return out = truth == 0, true;
  return false;
}

size_t YamlNode::size() const
{
  if (!IsSequence() && !IsMap())
    return 0;
  const uint32_t count = tree_->children[tree_->data[index_]];
  return IsMap() ? count / 2 : count;
}

YamlNode YamlNode::operator[](size_t index) const
{
  if (IsScalar())
    throw YAML::BadSubscript(Mark(), index);
  if (IsSequence())
    return index < size() ? YamlNode(tree_, tree_->children[tree_->data[index_] + 1 + index]) : YamlNode();
  if (IsMap())
    for (const YamlEntry& entry : *this)
    {
      size_t key = 0;
      if (entry.first.decode(key) && key == index)
        return entry.second;
    }
  return YamlNode();
}

YamlNode YamlNode::find(std::string_view key) const
{
  if (IsMap())
    for (const YamlEntry& entry : *this)
      if (entry.first.IsScalar() && entry.first.scalarView() == key)
        return entry.second;
  return YamlNode();
}

bool YamlNode::decode(std::string& out) const
{
  if (IsNull())
    return out = "null", true;
  if (!IsScalar())
    return false;
  out = Scalar();
  return true;
}

YamlIterator YamlNode::begin() const
{
  if (!IsSequence() && !IsMap())
    return YamlIterator(nullptr, nullptr, false);
  return YamlIterator(tree_, tree_->children.data() + tree_->data[index_] + 1, IsMap());
}

YamlIterator YamlNode::end() const
{
  if (!IsSequence() && !IsMap())
    return YamlIterator(nullptr, nullptr, false);
  const uint32_t at = tree_->data[index_];
  return YamlIterator(tree_, tree_->children.data() + at + 1 + tree_->children[at], IsMap());
}

YamlEntry YamlIterator::operator*() const
{
  YamlEntry entry;
  if (map_)
  {
    entry.first = YamlNode(tree_, at_[0]);
    entry.second = YamlNode(tree_, at_[1]);
  }
  else
    static_cast<YamlNode&>(entry) = YamlNode(tree_, at_[0]);
  return entry;
}

size_t YamlTree::memoryBytes() const
{
  const YamlTreeData& d = *data_;
  return sizeof(d) + capacityBytes(d.kind_pos) + capacityBytes(d.data) + capacityBytes(d.children) +
         d.chars.capacity() + capacityBytes(d.line_starts);
}

Expected<YamlTree> parseYamlTree(const std::string& text, size_t max_nodes, const std::string& source)
{
  if (text.size() > YamlTreeData::kPosMask)
    return Error(ErrorCode::kInvalidInput, source + ": " + std::to_string(text.size()) + " bytes, too large");
  YamlTree tree;
  try
  {
    TextBuffer buffer(text);
    std::istream stream(&buffer);
    YAML::Parser parser(stream);
    bool has_root = false;
    {
      TreeBuilder builder(*tree.data_, max_nodes, text.size());
      parser.HandleNextDocument(builder);
      has_root = builder.hasRoot();
    }  // frees the builder's stacks before the arrays are shrunk
    if (has_root)
      shrink(*tree.data_);
    else
    {
      tree.data_ = std::make_unique<YamlTreeData>();
      tree.data_->root = YamlTreeData::kInlineNull;
    }
  }
  catch (const ExpansionRefused&)
  {
    return Error(ErrorCode::kInvalidInput,
                 source + ": the document expands to more than " + std::to_string(max_nodes) +
                     " nodes (aliases that repeat or contain themselves?); write the values out instead");
  }
  catch (const YAML::Exception& e)
  {
    return Error(ErrorCode::kParseError, source + ": not valid YAML: " + e.what());
  }
  return tree;
}

}  // namespace yaml_util
}  // namespace insitu_calibration

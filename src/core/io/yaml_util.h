// YAML helpers shared by the file formats (read through io/yaml_tree.h, written with YAML::Emitter): conversions that
// report where the content is wrong instead of throwing. Internal to the core library.
#ifndef INSITU_CALIBRATION_SRC_CORE_IO_YAML_UTIL_H
#define INSITU_CALIBRATION_SRC_CORE_IO_YAML_UTIL_H

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "insitu_calibration/error.h"
#include "yaml_tree.h"

namespace insitu_calibration
{
namespace yaml_util
{
inline Expected<double> toDouble(const YamlNode& node, const std::string& where)
{
  if (!node || !node.IsScalar())
    return Error(ErrorCode::kParseError, where + ": expected a number");
  try
  {
    const double value = node.as<double>();
    if (!std::isfinite(value))
      return Error(ErrorCode::kInvalidInput, where + ": the value is NaN or infinite");
    return value;
  }
  catch (const YAML::Exception&)
  {
    return Error(ErrorCode::kParseError, where + ": '" + node.Scalar() + "' is not a number");
  }
}

inline Expected<int> toInt(const YamlNode& node, const std::string& where)
{
  if (!node || !node.IsScalar())
    return Error(ErrorCode::kParseError, where + ": expected an integer");
  try
  {
    return node.as<int>();
  }
  catch (const YAML::Exception&)
  {
    return Error(ErrorCode::kParseError, where + ": '" + node.Scalar() + "' is not an integer");
  }
}

inline Expected<std::vector<double>> toNumbers(const YamlNode& node, const std::string& where,
                                               std::optional<size_t> size = std::nullopt)
{
  if (!node || !node.IsSequence())
    return Error(ErrorCode::kParseError, where + ": expected a list of numbers");
  if (size && node.size() != *size)
    return Error(ErrorCode::kParseError,
                 where + ": expected " + std::to_string(*size) + " numbers, got " + std::to_string(node.size()));
  std::vector<double> out;
  for (size_t i = 0; i < node.size(); ++i)
  {
    const auto v = toDouble(node[i], where + "[" + std::to_string(i) + "]");
    if (!v)
      return v.error();
    out.push_back(*v);
  }
  return out;
}

template <int N>
Expected<Eigen::Matrix<double, N, 1>> toVector(const YamlNode& node, const std::string& where)
{
  const auto numbers = toNumbers(node, where, N);
  if (!numbers)
    return numbers.error();
  return Eigen::Matrix<double, N, 1>(Eigen::Map<const Eigen::Matrix<double, N, 1>>(numbers->data()));
}

// {rows: R, cols: C, data: [...]} in row-major order, as camera_calibration_parsers writes matrices.
template <int R, int C>
Expected<Eigen::Matrix<double, R, C>> toMatrix(const YamlNode& node, const std::string& where)
{
  if (!node || !node.IsMap())
    return Error(ErrorCode::kParseError, where + ": expected {rows, cols, data}");
  const auto rows = toInt(node["rows"], where + ".rows");
  const auto cols = toInt(node["cols"], where + ".cols");
  if (!rows || !cols)
    return !rows ? rows.error() : cols.error();
  if (*rows != R || *cols != C)
    return Error(ErrorCode::kParseError, where + ": expected a " + std::to_string(R) + "x" + std::to_string(C) +
                                             " matrix, got " + std::to_string(*rows) + "x" + std::to_string(*cols));
  const auto data = toNumbers(node["data"], where + ".data", R * C);
  if (!data)
    return data.error();
  return Eigen::Matrix<double, R, C>(Eigen::Map<const Eigen::Matrix<double, R, C, Eigen::RowMajor>>(data->data()));
}

// The largest YAML document a reader accepts. The tree takes about 12 bytes per node and a document has at most
// about one node per byte, so this bounds a reader's memory to about 100 MB whatever the file.
constexpr size_t kMaxYamlBytes = size_t{8} << 20;

// Parses a reader's document. An alias is shared, not copied, so a small file could describe an exponentially large
// tree (a "billion laughs") or, with an anchor used inside itself, a cyclic one, while every reader walks the
// expanded tree: the parse stops once the expansion has more nodes than an alias-free document of that many bytes
// could hold (at most one node per byte, with an allowance for tiny documents), which bounds every reader's work by
// its file's size.
inline Expected<YamlTree> parseYaml(const std::string& text, const std::string& source)
{
  if (text.size() > kMaxYamlBytes)
    return Error(ErrorCode::kInvalidInput, source + ": " + std::to_string(text.size()) + " bytes, more than the " +
                                               std::to_string(kMaxYamlBytes >> 20) + " MiB a file may have");
  return parseYamlTree(text, 2 * text.size() + 1024, source);
}

// Runs a reader's parse so that no yaml-cpp exception escapes it: a conversion that no explicit check caught (a
// scalar where a map is due, a key that is a list) becomes the usual parse error, with yaml-cpp's line and column.
template <typename T, typename Parse>
Expected<T> guarded(const std::string& source, Parse&& parse)
{
  try
  {
    return parse();
  }
  catch (const YAML::Exception& e)
  {
    return Error(ErrorCode::kParseError, source + ": unexpected content: " + e.what());
  }
  catch (const std::bad_alloc&)
  {
    return Error(ErrorCode::kInvalidInput, source + ": too large to hold in memory");
  }
}

// node[key] that never throws: undefined unless node is a map holding key.
inline YamlNode child(const YamlNode& node, const std::string& key)
{
  if (node && node.IsMap())
    if (YamlNode value = node[key])
      return value;
  return YamlNode();
}

// A count read from the file, refused above its documented limit before anything is allocated for it.
inline Status checkCount(size_t count, size_t limit, const std::string& where, const std::string& what)
{
  if (count > limit)
    return Error(ErrorCode::kInvalidInput, where + ": " + std::to_string(count) + " " + what + ", more than the " +
                                               std::to_string(limit) + " allowed");
  return Success{};
}

// Emits a matrix as camera_calibration_parsers does.
template <typename Derived>
void emitMatrix(YAML::Emitter& out, const std::string& key, const Eigen::MatrixBase<Derived>& m)
{
  out << YAML::Key << key << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "rows" << YAML::Value << static_cast<int>(m.rows());
  out << YAML::Key << "cols" << YAML::Value << static_cast<int>(m.cols());
  out << YAML::Key << "data" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int r = 0; r < m.rows(); ++r)
    for (int c = 0; c < m.cols(); ++c)
      out << m(r, c);
  out << YAML::EndSeq << YAML::EndMap;
}

template <typename Derived>
void emitVector(YAML::Emitter& out, const Eigen::MatrixBase<Derived>& v)
{
  out << YAML::Flow << YAML::BeginSeq;
  for (int i = 0; i < v.size(); ++i)
    out << v(i);
  out << YAML::EndSeq;
}

}  // namespace yaml_util
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SRC_CORE_IO_YAML_UTIL_H

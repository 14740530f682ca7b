// The tools' command-line parser: numbers, ranges and the errors a user sees.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "../../src/tools/command_line.h"

namespace ic = insitu_calibration;

namespace
{
ic::CommandLine parse(std::vector<std::string> args)
{
  args.insert(args.begin(), "tool");
  std::vector<char*> argv;
  for (std::string& a : args)
    argv.push_back(&a[0]);
  return ic::CommandLine(static_cast<int>(argv.size()), argv.data(), {"share", "count"}, {"fast"});
}
}  // namespace

TEST(CommandLine, ANumberInsideItsRangeIsRead)
{
  ic::CommandLine cli = parse({"--share", "0.2", "--fast", "file.txt"});
  EXPECT_DOUBLE_EQ(cli.number("share", 0.05, 0.0, 0.5), 0.2);
  EXPECT_DOUBLE_EQ(cli.number("count", 3.0, 0.0, 10.0), 3.0);  // not given: the fallback, no error
  EXPECT_TRUE(cli.flag("fast"));
  EXPECT_EQ(cli.positional(), std::vector<std::string>{"file.txt"});
  EXPECT_EQ(cli.error(), "");
}

TEST(CommandLine, ANumberOutsideItsRangeIsAnErrorThatNamesTheRange)
{
  ic::CommandLine cli = parse({"--share=0.8"});
  EXPECT_DOUBLE_EQ(cli.number("share", 0.05, 0.0, 0.5), 0.05);
  EXPECT_EQ(cli.error(), "option --share: 0.8 is outside [0, 0.5]");
}

TEST(CommandLine, NotANumberAndUnknownOptionsAreErrors)
{
  ic::CommandLine words = parse({"--share", "much"});
  EXPECT_DOUBLE_EQ(words.number("share", 0.05, 0.0, 0.5), 0.05);
  EXPECT_EQ(words.error(), "option --share: 'much' is not a number");
  EXPECT_EQ(parse({"--shares", "1"}).error(), "unknown option --shares");
  EXPECT_EQ(parse({"--count"}).error(), "option --count needs a value");
}

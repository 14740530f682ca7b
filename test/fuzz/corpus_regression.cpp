// The fuzzers' regression test, built with any compiler: feeds every file of a harness's committed corpus (the
// examples and every input that once crashed or hung) to the same LLVMFuzzerTestOneInput the fuzzer runs, and fails
// on a crash (the test dies) or an input that takes more than 10 s. FUZZ_CORPUS_DIR names the corpus directory;
// extra files or directories on the command line are run as well (to replay a crasher under gcc).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace
{
std::vector<std::string> g_extra_inputs;

std::vector<std::filesystem::path> inputsUnder(const std::filesystem::path& path)
{
  std::vector<std::filesystem::path> files;
  if (std::filesystem::is_directory(path))
  {
    for (const auto& entry : std::filesystem::directory_iterator(path))
      if (entry.is_regular_file())
        files.push_back(entry.path());
  }
  else
    files.push_back(path);
  std::sort(files.begin(), files.end());
  return files;
}
}  // namespace

TEST(FuzzCorpus, EveryInputReturnsWithinTenSeconds)
{
  std::vector<std::filesystem::path> files = inputsUnder(FUZZ_CORPUS_DIR);
  for (const auto& extra : g_extra_inputs)
    for (const auto& f : inputsUnder(extra))
      files.push_back(f);
  ASSERT_GE(files.size(), 1u) << "no corpus in " << FUZZ_CORPUS_DIR;
  for (const auto& file : files)
  {
    std::ifstream in(file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto start = std::chrono::steady_clock::now();
    LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, 10.0) << file;
  }
  std::printf("%zu inputs of %s\n", files.size(), FUZZ_CORPUS_DIR);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  g_extra_inputs.assign(argv + 1, argv + argc);
  return RUN_ALL_TESTS();
}

// Replays a fuzz target's corpus without libFuzzer (the normal g++ build; a ctest per target):
// every file named on the command line, or found under a folder named there, is fed once to
// LLVMFuzzerTestOneInput. A finding aborts (support/fuzz_support.h), which fails the test. Without
// AddressSanitizer the address space is limited to 3 GiB, like libFuzzer's malloc limit: a parser
// that sizes an allocation from a header field (an out-of-memory finding) fails here too.
#include <sys/resource.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
#if !defined(__SANITIZE_ADDRESS__)  // ASan reserves terabytes of shadow memory
  const rlimit limit{3ul << 30, 3ul << 30};
  setrlimit(RLIMIT_AS, &limit);
#endif
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    if (fs::is_directory(argv[i])) {
      for (const auto& e : fs::recursive_directory_iterator(argv[i]))
        if (e.is_regular_file()) files.push_back(e.path());
    } else if (fs::is_regular_file(argv[i])) {
      files.emplace_back(argv[i]);
    } else {
      std::fprintf(stderr, "replay: %s is neither a file nor a folder\n", argv[i]);
      return 2;
    }
  }
  std::sort(files.begin(), files.end());
  orpe::fuzz::set_print_refusals(true);
  if (files.empty()) {
    std::fprintf(stderr, "replay: no corpus files\n");
    return 2;
  }
  for (const fs::path& f : files) {
    std::ifstream is(f, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
    std::fprintf(stderr, "replay: %s (%zu bytes)\n", f.string().c_str(), bytes.size());
    LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  }
  const orpe::fuzz::RefusalCount count = orpe::fuzz::refusal_count();
  std::printf("replay: %zu inputs, no finding; %ld of %ld parser calls refused their input\n",
              files.size(), count.refused, count.calls);
  return 0;
}

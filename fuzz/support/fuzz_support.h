// Shared by the libFuzzer targets (fuzz/targets/*.cpp) and their corpus replay (replay_main.cpp):
// a per-process scratch folder for parsers that take a path, the input split into several files,
// and the rule that decides what a finding is. See docs/FUZZING.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace orpe::fuzz {

/// A fresh folder for this process, <dir>/orpe_fuzz_<pid> with <dir> = $TMPDIR, else /dev/shm (no
/// disk traffic per input), else the system's temporary folder; created on first use and removed
/// at exit. Also silences spdlog (the parsers' warnings would dominate the run time).
const std::string& scratch_dir();

/// scratch_dir()/relative, its parent folders created.
std::string scratch_path(const std::string& relative);

/// Writes `bytes` to `path` (replacing it). Aborts when the file cannot be written.
void write_file(const std::string& path, std::string_view bytes);

/// Writes `bytes` to `path`, or removes `path` when `present` is false (an optional file).
void write_or_remove(const std::string& path, std::string_view bytes, bool present);

/// The input split at each separator line "--" (the bytes "\n--\n"), into at most `max_parts`
/// parts; the last part keeps the rest, separators included. One part when there is no separator.
std::vector<std::string_view> split_parts(const uint8_t* data, size_t size, size_t max_parts);

/// Runs `fn`. An orpe::IoError or orpe::ConfigError (with a non-empty message) is the parser
/// refusing bad input, as it should; any other exception is a finding: it is printed and the
/// process aborts, so libFuzzer saves the input (a bare std::out_of_range or json::type_error
/// reaches the user as a message naming neither the file nor the problem).
void expect_clean_refusal(void (*fn)(void*), void* context);

/// How many calls of expect_clean_refusal ended in a refusal (IoError / ConfigError), and in all.
struct RefusalCount {
  long refused = 0, calls = 0;
};
RefusalCount refusal_count();
/// Print each refusal's message on stderr (the replay does; libFuzzer runs stay quiet).
void set_print_refusals(bool on);

template <class F>
void expect_clean_refusal(F&& fn) {
  using Fn = std::remove_reference_t<F>;
  expect_clean_refusal([](void* c) { (*static_cast<Fn*>(c))(); }, &fn);
}

/// Opens the dataset folder `path` as `format` and reads every frame's annotations (poses, objects)
/// and the ground-truth trajectory: everything a reader parses except the images.
void read_dataset_annotations(const std::string& path, const std::string& format);

}  // namespace orpe::fuzz

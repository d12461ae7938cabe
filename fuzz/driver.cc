// A fuzzing driver for relume's libFuzzer harnesses when they are built without libFuzzer (GCC,
// the Release and AddressSanitizer builds that CTest runs).
//
// It replays every seed of the corpus, then mutates seeds for a time budget: bit flips,
// interesting bytes and numbers, insertions, deletions, duplicated chunks, splices of two seeds
// and tokens taken from the seeds themselves. It has no coverage feedback: libFuzzer (clang,
// scripts/fuzz.sh) is the engine for long runs; this one keeps every harness running on every
// build, under the sanitizers, within a CI budget of seconds.
//
// A harness fails by crashing: a sanitizer report, an uncaught exception (std::terminate), or
// an input that runs longer than --timeout seconds. Before dying the driver writes the input to
// `<--artifacts>/crash-<hash>` and prints the command that replays it.
//
//   NAME [--seconds S] [--seed N] [--max-len BYTES] [--timeout S] [--artifacts DIR] CORPUS...
//
// CORPUS entries are files or folders (read recursively). With --seconds 0 only the seeds run.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <random>
#include <string>
#include <unordered_set>
#include <vector>

// The sanitizer runtime's death callback, when a sanitizer is linked (GCC says so with
// __SANITIZE_ADDRESS__, clang with __has_feature).
#if defined(__SANITIZE_ADDRESS__)
#define RELUME_HAVE_SANITIZER_CALLBACK 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RELUME_HAVE_SANITIZER_CALLBACK 1
#endif
#endif
#ifdef RELUME_HAVE_SANITIZER_CALLBACK
#include <sanitizer/common_interface_defs.h>
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

// The input being run, for the crash handlers (plain globals: they run in signal context).
const Bytes* g_current = nullptr;
std::string g_artifacts = ".";
std::string g_program;

std::uint64_t Fnv1a(const Bytes& bytes) {
  std::uint64_t hash = 1469598103934665603ull;
  for (std::uint8_t b : bytes) hash = (hash ^ b) * 1099511628211ull;
  return hash;
}

// Writes the current input beside the artifacts and says how to replay it. open(2) and write(2)
// only (snprintf into stack buffers aside): this also runs from a signal handler.
void SaveCurrentInput(const char* why) {
  const Bytes* input = g_current;
  if (input == nullptr) return;
  g_current = nullptr;
  char path[4096];
  std::snprintf(path, sizeof(path), "%s/crash-%016llx", g_artifacts.c_str(),
                static_cast<unsigned long long>(Fnv1a(*input)));
  const int fd = ::open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd >= 0) {
    for (std::size_t done = 0; done < input->size();) {
      const ssize_t n = ::write(fd, input->data() + done, input->size() - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
    ::close(fd);
  }
  char message[8192];
  const int length = std::snprintf(message, sizeof(message),
                                   "\nfuzz: %s on an input of %zu bytes, saved as %s\nfuzz: replay with: %s "
                                   "--seconds 0 %s\n",
                                   why, input->size(), path, g_program.c_str(), path);
  if (length > 0) {
    [[maybe_unused]] const ssize_t written =
        ::write(STDERR_FILENO, message, std::min(static_cast<std::size_t>(length), sizeof(message) - 1));
  }
}

void OnTerminate() {
  const char* what = "an uncaught exception";
  std::string message;
  if (std::exception_ptr e = std::current_exception()) {
    try {
      std::rethrow_exception(e);
    } catch (const std::exception& ex) {
      message = std::string("an uncaught exception: ") + ex.what();
      what = message.c_str();
    } catch (...) {
    }
  }
  SaveCurrentInput(what);
  std::abort();
}

void OnSignal(int signal) {
  SaveCurrentInput(signal == SIGALRM ? "a time-out" : "a fatal signal");
  std::signal(signal, SIG_DFL);
  std::raise(signal == SIGALRM ? SIGABRT : signal);
}

#ifdef RELUME_HAVE_SANITIZER_CALLBACK
void OnSanitizerDeath() {
  SaveCurrentInput("a sanitizer report");
}
#endif

Bytes ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Tokens of the seeds (identifier- and number-like runs), for text formats: a mutation may put
// `scene:` where a number was, or a number where a key was.
std::vector<Bytes> Tokens(const std::vector<Bytes>& seeds) {
  std::unordered_set<std::string> seen;
  std::vector<Bytes> tokens;
  for (const Bytes& seed : seeds) {
    std::string token;
    for (std::uint8_t c : seed) {
      if (std::isalnum(c) || c == '_' || c == '.' || c == '-' || c == ':') {
        token.push_back(static_cast<char>(c));
        continue;
      }
      if (token.size() >= 2 && token.size() <= 32 && seen.insert(token).second) {
        tokens.emplace_back(token.begin(), token.end());
      }
      token.clear();
      if (tokens.size() > 4096) return tokens;
    }
  }
  return tokens;
}

class Mutator {
 public:
  Mutator(std::uint64_t seed, std::vector<Bytes> seeds, std::size_t max_len)
      : rng_(seed), seeds_(std::move(seeds)), tokens_(Tokens(seeds_)), max_len_(max_len) {}

  Bytes Next() {
    Bytes input = seeds_.empty() ? Bytes{} : seeds_[Pick(seeds_.size())];
    const int count = 1 + static_cast<int>(Pick(8));
    for (int k = 0; k < count; ++k) Mutate(input);
    if (input.size() > max_len_) input.resize(max_len_);
    return input;
  }

 private:
  std::size_t Pick(std::size_t n) { return n == 0 ? 0 : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng_); }

  void Insert(Bytes& input, const Bytes& what) {
    const std::size_t at = Pick(input.size() + 1);
    input.insert(input.begin() + static_cast<std::ptrdiff_t>(at), what.begin(), what.end());
  }

  void Mutate(Bytes& input) {
    static const char* kNumbers[] = {"0",    "-1",         "1e308", "-1e308", "nan",   "inf",          "2147483648",
                                     "1e12", "4294967296", "-0",    "1e-320", "65536", "999999999999", "0x7fffffff"};
    static const std::uint8_t kBytes[] = {0x00, 0xff, 0x7f, 0x80, 0x01, 0xfe, '\n', ':', '-', '[', '{', '"', '\0'};
    switch (Pick(input.empty() ? 3 : 10)) {
      case 0: {  // a number where something was
        const char* n = kNumbers[Pick(std::size(kNumbers))];
        Insert(input, Bytes(n, n + std::strlen(n)));
        break;
      }
      case 1:  // a token of the seeds
        if (!tokens_.empty()) Insert(input, tokens_[Pick(tokens_.size())]);
        break;
      case 2: {  // a splice of another seed
        if (seeds_.empty()) break;
        const Bytes& other = seeds_[Pick(seeds_.size())];
        const std::size_t from = Pick(other.size() + 1);
        const std::size_t length = Pick(other.size() - from + 1);
        Insert(input, Bytes(other.begin() + static_cast<std::ptrdiff_t>(from),
                            other.begin() + static_cast<std::ptrdiff_t>(from + length)));
        break;
      }
      case 3:  // flip a bit
        input[Pick(input.size())] ^= static_cast<std::uint8_t>(1u << Pick(8));
        break;
      case 4:  // an interesting byte
        input[Pick(input.size())] = kBytes[Pick(std::size(kBytes))];
        break;
      case 5:  // a random byte
        input[Pick(input.size())] = static_cast<std::uint8_t>(Pick(256));
        break;
      case 6: {  // delete a range
        const std::size_t from = Pick(input.size());
        const std::size_t length = 1 + Pick(std::min<std::size_t>(input.size() - from, 64));
        input.erase(input.begin() + static_cast<std::ptrdiff_t>(from),
                    input.begin() + static_cast<std::ptrdiff_t>(from + length));
        break;
      }
      case 7: {  // duplicate a chunk
        const std::size_t from = Pick(input.size());
        const std::size_t length = 1 + Pick(std::min<std::size_t>(input.size() - from, 64));
        Insert(input, Bytes(input.begin() + static_cast<std::ptrdiff_t>(from),
                            input.begin() + static_cast<std::ptrdiff_t>(from + length)));
        break;
      }
      case 8: {  // a 32-bit little-endian field set to an extreme (binary formats: sizes, offsets)
        if (input.size() < 4) break;
        static const std::uint32_t kWords[] = {0, 1, 0x7fffffff, 0x80000000, 0xffffffff, 0x10000, 0xfffffffe};
        const std::uint32_t word = kWords[Pick(std::size(kWords))];
        std::memcpy(input.data() + Pick(input.size() - 3), &word, 4);
        break;
      }
      default: {  // truncate
        input.resize(Pick(input.size() + 1));
        break;
      }
    }
  }

  std::mt19937_64 rng_;
  std::vector<Bytes> seeds_;
  std::vector<Bytes> tokens_;
  std::size_t max_len_;
};

struct Args {
  double seconds = 0.0;
  std::uint64_t seed = 1;
  std::size_t max_len = 1 << 16;
  unsigned timeout = 10;
  std::vector<fs::path> corpus;
};

Args Parse(int argc, char** argv) {
  Args args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "fuzz: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--seconds") {
      args.seconds = std::stod(value());
    } else if (a == "--seed") {
      args.seed = std::stoull(value());
    } else if (a == "--max-len") {
      args.max_len = std::stoull(value());
    } else if (a == "--timeout") {
      args.timeout = static_cast<unsigned>(std::stoul(value()));
    } else if (a == "--artifacts") {
      g_artifacts = value();
    } else if (a.starts_with("--")) {
      std::fprintf(stderr, "fuzz: unknown option %s\n", a.c_str());
      std::exit(2);
    } else {
      args.corpus.emplace_back(a);
    }
  }
  return args;
}

std::vector<Bytes> LoadCorpus(const std::vector<fs::path>& entries) {
  std::vector<fs::path> files;
  for (const fs::path& entry : entries) {
    if (fs::is_directory(entry)) {
      for (const auto& f : fs::recursive_directory_iterator(entry)) {
        if (f.is_regular_file()) files.push_back(f.path());
      }
    } else if (fs::is_regular_file(entry)) {
      files.push_back(entry);
    } else {
      std::fprintf(stderr, "fuzz: corpus entry %s is neither a file nor a folder\n", entry.c_str());
      std::exit(2);
    }
  }
  std::sort(files.begin(), files.end());
  std::vector<Bytes> seeds;
  for (const fs::path& f : files) seeds.push_back(ReadFile(f));
  return seeds;
}

void RunOne(const Bytes& input, unsigned timeout) {
  g_current = &input;
  ::alarm(timeout);
  LLVMFuzzerTestOneInput(input.data(), input.size());
  ::alarm(0);
  g_current = nullptr;
}

}  // namespace

int main(int argc, char** argv) {
  g_program = argv[0];
  const Args args = Parse(argc, argv);
  std::set_terminate(OnTerminate);
  std::signal(SIGALRM, OnSignal);  // the per-input time-out
#ifdef RELUME_HAVE_SANITIZER_CALLBACK
  // The sanitizer handles fatal signals itself (its report has the stack) and calls back first.
  __sanitizer_set_death_callback(OnSanitizerDeath);
#else
  for (int s : {SIGSEGV, SIGBUS, SIGFPE, SIGILL}) std::signal(s, OnSignal);
#endif
  const std::vector<Bytes> seeds = LoadCorpus(args.corpus);
  const auto start = std::chrono::steady_clock::now();
  for (const Bytes& seed : seeds) RunOne(seed, args.timeout);
  Mutator mutator(args.seed, seeds, args.max_len);
  std::uint64_t runs = 0;
  const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  while (elapsed() < args.seconds) {
    for (int k = 0; k < 16; ++k, ++runs) RunOne(mutator.Next(), args.timeout);
  }
  const double seconds = elapsed();
  std::printf("fuzz %s: %zu seeds replayed, %llu mutated inputs in %.1f s (%.0f/s), no crash\n",
              fs::path(g_program).filename().c_str(), seeds.size(), static_cast<unsigned long long>(runs), seconds,
              seconds > 0 ? static_cast<double>(runs + seeds.size()) / seconds : 0.0);
  return 0;
}

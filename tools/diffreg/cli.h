// What the diffreg commands share: usage errors, output checks and outputs that appear together
// or not at all.
#pragma once

#include <diffreg/core/staged_outputs.h>

#include <boost/program_options.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace diffreg {

/// A report as written to --report: indented JSON and a final newline. Strings that are not
/// UTF-8 (parameters given on the command line) have their bad bytes replaced by U+FFFD
/// instead of failing the run at the end.
inline std::string reportText(const nlohmann::json& report) {
  return report.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

/// A mistake in the command line itself (exit code 2).
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string join(const std::vector<std::string>& items, const char* separator);

/// The main() of a diffreg executable: keeps the BLAS's threads for supernodal factors (the
/// element loops use every core), runs `body` and turns what it throws into one line
/// "diffreg: error: ..." on stderr. Returns body's exit code, 2 for a UsageError or a bad
/// option, else 1; an out-of-memory error names the input being worked on (currentInput()).
int runCommand(const std::function<int()>& body);

/// The input mesh of the running command as given with -i (empty before the options are
/// parsed): what an out-of-memory error names.
std::string& currentInput();

/// Parses a command's options into `vm`. With --help prints `usage` and the options and returns
/// false (nothing else to do); applies --quiet when the options have it and records -i as the
/// currentInput().
bool parseCommandLine(int argc, char** argv, const char* usage,
                      const boost::program_options::options_description& options,
                      boost::program_options::variables_map& vm);

/// \throw UsageError "COMMAND: missing WHAT (see diffreg COMMAND --help)" unless `vm` has `key`.
void requireOption(const boost::program_options::variables_map& vm, const std::string& key,
                   const std::string& command, const std::string& what);

/// `value` with `digits` decimals, or in scientific notation with `digits` significant digits
/// when |value| < 1e-3 or >= 1e5 (0 stays fixed); "-" when not finite. For tables.
std::string fixed(double value, int digits);

/// Parses a picture size "WxH" given to `command`'s --size.
/// \throw UsageError unless both are whole numbers in [100, 4000].
void parseSize(const std::string& command, const std::string& size, int& width, int& height);

/// `command`'s --up: "x", "y" or "z" as 0, 1, 2; "auto" as -1 (uprightAxis of the frame).
/// \throw UsageError for anything else.
int parseUp(const std::string& command, const std::string& up);

/// The extensions of a picture output (-o of compare and resolution).
inline const std::vector<std::string> kPictureExtensions = {"png"};

/// checkWritableDir, and (when `extensions` is not empty) the extension of `path` is one of
/// them (lower case, without the dot). \throw IoError naming `path`.
void checkOutputTarget(const std::string& path, const std::vector<std::string>& extensions = {});

/// Prints a long filter's iterations on stderr (unless quiet): nothing during the first
/// `after` seconds of the run, then at most one line a second, "diffreg: FILTER: iteration N,
/// energy E".
class ProgressPrinter {
 public:
  explicit ProgressPrinter(double after) : after_(after) {}
  void operator()(const std::string& filter, int iteration, double energy, double criterion);

 private:
  double after_;
  double last_ = -1.0;  // when the last line was printed (seconds since construction)
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

/// The outputs of a table command (compare, resolution) in `vm`: -o (a picture), --report and
/// --markdown, each checked by checkOutputTarget before any work starts.
/// \throw UsageError "COMMAND: output 'PATH' given twice" for two spellings of one file.
void checkTableOutputs(const boost::program_options::variables_map& vm, const std::string& command);

/// Writes a table command's outputs all or nothing: the picture by `drawPicture` (given the
/// temporary path) with -o, the report `makeReport` builds with --report, `table` with
/// --markdown. Then prints `table` on stdout and names the files written.
/// The picture and report are only made when asked for.
void writeTableOutputs(const boost::program_options::variables_map& vm, const std::string& table,
                       const std::function<void(const std::string&)>& drawPicture,
                       const std::function<nlohmann::json()>& makeReport);

}  // namespace diffreg

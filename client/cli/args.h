// The `myriad` command line: every subcommand's options, and the parser that turns argv into an
// Invocation. No I/O here (no environment, no files, no network), so all of it is unit-tested;
// what the options mean to the server is decided in the command files.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

namespace myriad::cli {

using Vec3 = std::array<double, 3>;
using Vec4 = std::array<double, 4>;

// `min,max`, as in `--radius 0.5,2`.
struct Interval {
  double min = 0.0;
  double max = 0.0;
};

// A parsed argument value. Which alternative an option holds follows from its Kind.
using Value = std::variant<bool, double, uint64_t, std::string, Vec3, Interval, Vec4,
                           std::optional<uint64_t>>;

enum class Kind {
  Flag,      // no value: present or not (bool)
  Number,    // a finite number (double)
  Unsigned,  // a whole number >= 0 (uint64_t)
  Text,      // any text (std::string)
  Choice,    // one of `choices` (std::string)
  OnOff,     // on|off (bool); also true|false, 1|0
  Vector,    // x,y,z: three finite numbers (Vec3)
  Range,     // min,max: two finite numbers with min <= max (Interval)
  Rotation,  // x,y,z,w: a quaternion, four finite numbers not all 0 (Vec4)
  Scale,     // s or x,y,z: one number for all three axes, or three (Vec3)
  IdOrNone,  // a whole number >= 0, or none (std::optional<uint64_t>, nullopt for none)
  // A whole number within bounds (uint64_t), or else a name of 1-64 characters (std::string):
  // an object's semantic class.
  NumberOrName,
};

// Accepted values of a number, or of each component of a vector or range.
struct Bounds {
  double min = 0.0;
  double max = 0.0;
  bool minOpen = false;  // min itself is not allowed
  bool maxOpen = false;
  std::string unit;      // shown in messages: "degrees"
};

struct OptionSpec {
  std::string name;  // without dashes: "eye" is given as --eye
  Kind kind = Kind::Flag;
  std::string metavar;  // "x,y,z"
  std::string help;
  std::optional<Bounds> bounds;
  std::vector<std::string> choices;
  char shortName = 0;  // 'o' for -o
  bool required = false;
};

struct PositionalSpec {
  std::string name;  // "ID"
  Kind kind = Kind::Text;
  std::string help;
  std::optional<Bounds> bounds;
  bool optional = false;
};

struct Invocation;

struct CommandSpec {
  std::string name;  // "lights add": the words that select it
  std::string summary;
  std::vector<PositionalSpec> positionals;
  std::vector<OptionSpec> options;
  std::string notes;  // printed after the options in --help
  // Checks that involve several options (throws UsageError).
  std::function<void(const Invocation&)> check;
};

// Options that every subcommand takes, before or after its name.
struct GlobalOptions {
  std::optional<std::string> server;       // --server URL
  std::optional<std::string> sessionFile;  // --session-file PATH
  bool json = false;                       // --json: print the server's JSON as it came
  // --if-match TAG: every edit is conditional on the session still being at that ETag (a 412,
  // exit status 1, when it is not); see protocol/reference.md "Conditional edits".
  std::optional<std::string> ifMatch;
};

struct Invocation {
  GlobalOptions global;
  const CommandSpec* command = nullptr;  // null with `help`: the overview
  bool help = false;                     // -h/--help: print help, do nothing else
  bool version = false;                  // --version: print the version, do nothing else
  std::map<std::string, Value> options;  // by OptionSpec::name; only those given
  std::vector<Value> positionals;

  bool has(const std::string& name) const { return options.count(name) != 0; }
  template <typename T>
  const T& get(const std::string& name) const {
    return std::get<T>(options.at(name));
  }
  template <typename T>
  std::optional<T> find(const std::string& name) const {
    auto it = options.find(name);
    if (it == options.end()) return std::nullopt;
    return std::get<T>(it->second);
  }
};

// A mistake on the command line. `argument` names the offending argument as the user typed it
// ("--fov", "lights", "ID"); what() is the whole sentence.
class UsageError : public std::runtime_error {
 public:
  UsageError(std::string argument, const std::string& message, std::string command = {})
      : std::runtime_error(message), argument_(std::move(argument)), command_(std::move(command)) {}
  const std::string& argument() const { return argument_; }
  const std::string& command() const { return command_; }  // for the "see --help" hint

 private:
  std::string argument_;
  std::string command_;
};

// Every subcommand, in the order the overview lists them.
const std::vector<CommandSpec>& commandSpecs();
const CommandSpec* findCommand(const std::string& name);

// `args` excludes argv[0]. Throws UsageError.
Invocation parseArguments(const std::vector<std::string>& args);

// --help text of one subcommand, and of `myriad` itself.
std::string commandHelp(const CommandSpec& command);
std::string overviewHelp();

// Value parsers, exposed for the tests and for the few places outside argv that need them.
// `what` names the argument in the error ("--eye").
double parseNumber(const std::string& text, const std::string& what);
uint64_t parseUnsigned(const std::string& text, const std::string& what);
Vec3 parseVector(const std::string& text, const std::string& what);
Interval parseRange(const std::string& text, const std::string& what);
Vec4 parseRotation(const std::string& text, const std::string& what);
Vec3 parseScale(const std::string& text, const std::string& what);
std::optional<uint64_t> parseIdOrNone(const std::string& text, const std::string& what);
bool parseOnOff(const std::string& text, const std::string& what);

}  // namespace myriad::cli

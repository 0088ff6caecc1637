#include "args.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>


namespace myriad::cli {
namespace {

std::string formatNumber(double value) {
  // Whole numbers in full (1000000, not 1e+06): they are limits people type back.
  if (std::floor(value) == value && std::fabs(value) < 1e16) {
    return std::to_string(static_cast<long long>(value));
  }
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string describeBounds(const Bounds& b) {
  std::string text;
  if (std::isinf(b.max)) {
    text = (b.minOpen ? "above " : "at least ") + formatNumber(b.min);
  } else if (!b.minOpen && !b.maxOpen) {
    text = "from " + formatNumber(b.min) + " to " + formatNumber(b.max);
  } else {
    text = std::string(b.minOpen ? "above " : "at least ") + formatNumber(b.min) +
           (b.maxOpen ? " and below " : " and at most ") + formatNumber(b.max);
  }
  if (!b.unit.empty()) text += " " + b.unit;
  return text;
}

void checkBounds(double value, const std::optional<Bounds>& bounds, const std::string& what,
                 const std::string& shown) {
  if (!bounds) return;
  const Bounds& b = *bounds;
  bool low = b.minOpen ? value <= b.min : value < b.min;
  bool high = b.maxOpen ? value >= b.max : value > b.max;
  if (low || high) {
    throw UsageError(what, what + ": " + shown + " is out of range: must be " + describeBounds(b));
  }
}

std::vector<std::string> splitComma(const std::string& text) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    size_t comma = text.find(',', start);
    parts.push_back(text.substr(start, comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return parts;
}

bool isOption(const std::string& arg) { return arg.size() > 1 && arg[0] == '-'; }

std::string optionDisplayName(const OptionSpec& o) { return "--" + o.name; }

// Parses `text` as the value of an argument of `kind`, checking bounds and choices.
Value parseValue(Kind kind, const std::string& text, const std::string& what,
                 const std::optional<Bounds>& bounds, const std::vector<std::string>& choices) {
  switch (kind) {
    case Kind::Flag:
      return true;
    case Kind::Number: {
      double v = parseNumber(text, what);
      checkBounds(v, bounds, what, text);
      return v;
    }
    case Kind::Unsigned: {
      uint64_t v = parseUnsigned(text, what);
      checkBounds(double(v), bounds, what, text);
      return v;
    }
    case Kind::Text:
      if (text.empty()) throw UsageError(what, what + ": the value is empty");
      return text;
    case Kind::Choice: {
      for (const std::string& c : choices) {
        if (c == text) return text;
      }
      std::string list;
      for (const std::string& c : choices) list += (list.empty() ? "" : ", ") + c;
      throw UsageError(what, what + ": \"" + text + "\" is not one of " + list);
    }
    case Kind::OnOff:
      return parseOnOff(text, what);
    case Kind::Vector: {
      Vec3 v = parseVector(text, what);
      for (double c : v) checkBounds(c, bounds, what, formatNumber(c));
      return v;
    }
    case Kind::Range: {
      Interval r = parseRange(text, what);
      checkBounds(r.min, bounds, what, formatNumber(r.min));
      checkBounds(r.max, bounds, what, formatNumber(r.max));
      return r;
    }
    case Kind::Rotation: {
      Vec4 q = parseRotation(text, what);
      for (double c : q) checkBounds(c, bounds, what, formatNumber(c));
      return q;
    }
    case Kind::Scale: {
      Vec3 v = parseScale(text, what);
      for (double c : v) checkBounds(c, bounds, what, formatNumber(c));
      return v;
    }
    case Kind::IdOrNone: {
      std::optional<uint64_t> id = parseIdOrNone(text, what);
      if (id) checkBounds(double(*id), bounds, what, text);
      return id;
    }
    case Kind::NumberOrName: {
      if (!text.empty() && std::all_of(text.begin(), text.end(),
                                       [](char c) { return c >= '0' && c <= '9'; })) {
        uint64_t v = parseUnsigned(text, what);
        checkBounds(double(v), bounds, what, text);
        return v;
      }
      if (text.empty() || text.size() > 64) {
        throw UsageError(what, what + ": a number or a name of 1 to 64 characters");
      }
      return text;
    }
  }
  throw UsageError(what, what + ": unsupported kind of value");
}

std::string kindHint(Kind kind) {
  switch (kind) {
    case Kind::Vector:
      return "x,y,z";
    case Kind::Range:
      return "min,max";
    case Kind::Rotation:
      return "x,y,z,w";
    case Kind::Scale:
      return "s|x,y,z";
    case Kind::IdOrNone:
      return "N|none";
    case Kind::NumberOrName:
      return "N|NAME";
    case Kind::OnOff:
      return "on|off";
    case Kind::Unsigned:
      return "N";
    case Kind::Number:
      return "NUMBER";
    default:
      return "VALUE";
  }
}

std::string metavarOf(const OptionSpec& o) {
  if (o.kind == Kind::Flag) return "";
  if (!o.metavar.empty()) return o.metavar;
  if (o.kind == Kind::Choice) {
    std::string list;
    for (const std::string& c : o.choices) list += (list.empty() ? "" : "|") + c;
    return list;
  }
  return kindHint(o.kind);
}

const OptionSpec* findOption(const CommandSpec& command, const std::string& name, char shortName) {
  for (const OptionSpec& o : command.options) {
    if (shortName != 0 ? o.shortName == shortName : o.name == name) return &o;
  }
  return nullptr;
}

// Handles --server, --session-file, --if-match, --json, -h/--help. Returns how many arguments it used (0 when
// `args[i]` is not a global option).
size_t takeGlobal(const std::vector<std::string>& args, size_t i, Invocation& inv) {
  const std::string& arg = args[i];
  std::string name = arg;
  std::optional<std::string> inlineValue;
  if (arg.starts_with("--")) {
    if (size_t eq = arg.find('='); eq != std::string::npos) {
      name = arg.substr(0, eq);
      inlineValue = arg.substr(eq + 1);
    }
  }
  if (name == "-h" || name == "--help") {
    inv.help = true;
    return 1;
  }
  if (name == "--version") {
    if (inlineValue) throw UsageError("--version", "--version takes no value");
    inv.version = true;
    return 1;
  }
  if (name == "--json") {
    if (inlineValue) throw UsageError("--json", "--json takes no value");
    inv.global.json = true;
    return 1;
  }
  if (name == "--server" || name == "--session-file" || name == "--if-match") {
    std::string value;
    size_t used = 1;
    if (inlineValue) {
      value = *inlineValue;
    } else if (i + 1 < args.size()) {
      value = args[i + 1];
      used = 2;
    } else {
      throw UsageError(name, name + " needs a value (" +
                                 (name == "--server"     ? "a URL such as http://127.0.0.1:8080"
                                  : name == "--if-match" ? "an ETag such as \"12-0a1b2c3d\""
                                                         : "a file path") +
                                 ")");
    }
    if (value.empty()) throw UsageError(name, name + ": the value is empty");
    (name == "--server"     ? inv.global.server
     : name == "--if-match" ? inv.global.ifMatch
                            : inv.global.sessionFile) = value;
    return used;
  }
  return 0;
}

std::string groupSubcommands(const std::string& group) {
  std::string list;
  for (const CommandSpec& c : commandSpecs()) {
    if (c.name.starts_with(group + " ")) list += (list.empty() ? "" : ", ") + c.name.substr(group.size() + 1);
  }
  return list;
}

}  // namespace

double parseNumber(const std::string& text, const std::string& what) {
  if (text.empty()) throw UsageError(what, what + ": expected a number, got nothing");
  errno = 0;
  char* end = nullptr;
  double v = std::strtod(text.c_str(), &end);
  // strtod takes "nan", "inf" and hex floats; none of them is a number a person means here.
  bool plain = text.find_first_not_of("0123456789+-.eE") == std::string::npos;
  if (end != text.c_str() + text.size() || !plain || !std::isfinite(v) || errno == ERANGE) {
    throw UsageError(what, what + ": expected a finite number, got \"" + text + "\"");
  }
  return v;
}

uint64_t parseUnsigned(const std::string& text, const std::string& what) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) {
    throw UsageError(what, what + ": expected a whole number >= 0, got \"" + text + "\"");
  }
  errno = 0;
  unsigned long long v = std::strtoull(text.c_str(), nullptr, 10);
  if (errno == ERANGE) throw UsageError(what, what + ": " + text + " is too large");
  return v;
}

Vec3 parseVector(const std::string& text, const std::string& what) {
  std::vector<std::string> parts = splitComma(text);
  if (parts.size() != 3) {
    throw UsageError(what, what + ": expected three numbers x,y,z, got \"" + text + "\"");
  }
  return {parseNumber(parts[0], what), parseNumber(parts[1], what), parseNumber(parts[2], what)};
}

Interval parseRange(const std::string& text, const std::string& what) {
  std::vector<std::string> parts = splitComma(text);
  if (parts.size() != 2) {
    throw UsageError(what, what + ": expected two numbers min,max, got \"" + text + "\"");
  }
  Interval r{parseNumber(parts[0], what), parseNumber(parts[1], what)};
  if (r.min > r.max) {
    throw UsageError(what, what + ": min " + parts[0] + " is above max " + parts[1]);
  }
  return r;
}

Vec4 parseRotation(const std::string& text, const std::string& what) {
  std::vector<std::string> parts = splitComma(text);
  if (parts.size() != 4) {
    throw UsageError(what, what + ": expected a quaternion of four numbers x,y,z,w, got \"" +
                               text + "\"");
  }
  Vec4 q{parseNumber(parts[0], what), parseNumber(parts[1], what), parseNumber(parts[2], what),
         parseNumber(parts[3], what)};
  if (q[0] == 0 && q[1] == 0 && q[2] == 0 && q[3] == 0) {
    throw UsageError(what, what + ": 0,0,0,0 is no rotation (the identity is 0,0,0,1)");
  }
  return q;
}

Vec3 parseScale(const std::string& text, const std::string& what) {
  std::vector<std::string> parts = splitComma(text);
  if (parts.size() == 1) {
    double s = parseNumber(parts[0], what);
    return {s, s, s};
  }
  if (parts.size() != 3) {
    throw UsageError(what, what + ": expected one number s or three x,y,z, got \"" + text + "\"");
  }
  return {parseNumber(parts[0], what), parseNumber(parts[1], what), parseNumber(parts[2], what)};
}

std::optional<uint64_t> parseIdOrNone(const std::string& text, const std::string& what) {
  if (text == "none") return std::nullopt;
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) {
    throw UsageError(what, what + ": expected a whole number >= 0 or none, got \"" + text + "\"");
  }
  return parseUnsigned(text, what);
}

bool parseOnOff(const std::string& text, const std::string& what) {
  if (text == "on" || text == "true" || text == "1") return true;
  if (text == "off" || text == "false" || text == "0") return false;
  throw UsageError(what, what + ": expected on or off, got \"" + text + "\"");
}

const CommandSpec* findCommand(const std::string& name) {
  for (const CommandSpec& c : commandSpecs()) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

Invocation parseArguments(const std::vector<std::string>& args) {
  Invocation inv;
  size_t i = 0;

  // Global options may come before the subcommand's name...
  while (i < args.size() && isOption(args[i])) {
    size_t used = takeGlobal(args, i, inv);
    if (used == 0) {
      throw UsageError(args[i], "unknown option " + args[i] + " before the subcommand");
    }
    i += used;
  }
  if (i == args.size()) {
    if (inv.help || inv.version) return inv;
    throw UsageError("", "no subcommand given");
  }

  // `myriad help [COMMAND]`: the overview, or that command's help (as `myriad COMMAND --help`).
  if (args[i] == "help") {
    inv.help = true;
    if (i + 1 == args.size()) return inv;
    if (i + 2 < args.size()) inv.command = findCommand(args[i + 1] + " " + args[i + 2]);
    if (inv.command == nullptr) inv.command = findCommand(args[i + 1]);
    if (inv.command == nullptr && groupSubcommands(args[i + 1]).empty()) {
      throw UsageError(args[i + 1], "unknown command \"" + args[i + 1] +
                                        "\"; myriad help lists the commands");
    }
    return inv;
  }

  // ...whose name is one or two words: the longest that names a command wins.
  const std::string first = args[i];
  if (i + 1 < args.size()) {
    if (const CommandSpec* c = findCommand(first + " " + args[i + 1])) {
      inv.command = c;
      i += 2;
    }
  }
  if (inv.command == nullptr) {
    inv.command = findCommand(first);
    if (inv.command == nullptr) {
      std::string subs = groupSubcommands(first);
      if (!subs.empty()) {
        // `myriad lights --help`: the overview lists the group's commands.
        for (size_t j = i; j < args.size(); ++j) {
          if (args[j] == "-h" || args[j] == "--help") inv.help = true;
        }
        if (inv.help) return inv;
        if (i + 1 < args.size() && !isOption(args[i + 1])) {
          throw UsageError(args[i + 1], "unknown subcommand \"" + first + " " + args[i + 1] +
                                            "\"; " + first + " takes: " + subs);
        }
        throw UsageError(first, "\"" + first + "\" needs a subcommand: " + subs);
      }
      throw UsageError(first, "unknown subcommand \"" + first + "\"");
    }
    i += 1;
  }
  const CommandSpec& command = *inv.command;
  const std::string commandName = command.name;

  bool optionsEnded = false;
  std::vector<std::string> positionalTexts;
  for (; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (optionsEnded || !isOption(arg)) {
      positionalTexts.push_back(arg);
      continue;
    }
    if (arg == "--") {
      optionsEnded = true;
      continue;
    }
    if (size_t used = takeGlobal(args, i, inv)) {
      i += used - 1;
      continue;
    }
    // --name, --name=value, -x
    std::string name;
    std::optional<std::string> inlineValue;
    const OptionSpec* spec = nullptr;
    if (arg.starts_with("--")) {
      name = arg.substr(2);
      if (size_t eq = name.find('='); eq != std::string::npos) {
        inlineValue = name.substr(eq + 1);
        name = name.substr(0, eq);
      }
      spec = findOption(command, name, 0);
    } else if (arg.size() == 2) {
      spec = findOption(command, "", arg[1]);
    }
    std::string shown = arg.starts_with("--") ? "--" + name : arg;
    if (spec == nullptr) {
      throw UsageError(shown, "unknown option " + shown + " for \"" + commandName + "\"",
                       commandName);
    }
    if (inv.options.count(spec->name) != 0) {
      throw UsageError(shown, shown + " is given more than once", commandName);
    }
    if (spec->kind == Kind::Flag) {
      if (inlineValue) throw UsageError(shown, shown + " takes no value", commandName);
      inv.options[spec->name] = true;
      continue;
    }
    std::string value;
    if (inlineValue) {
      value = *inlineValue;
    } else if (i + 1 < args.size()) {
      // The next argument is the value even when it starts with '-': `--eye -1,2,3`, `-o -`.
      value = args[++i];
    } else {
      throw UsageError(shown, shown + " needs a value (" + metavarOf(*spec) + ")", commandName);
    }
    try {
      inv.options[spec->name] = parseValue(spec->kind, value, shown, spec->bounds, spec->choices);
    } catch (const UsageError& e) {
      throw UsageError(e.argument(), e.what(), commandName);
    }
  }
  if (inv.help) return inv;

  // Positionals, in order; the optional ones come last.
  size_t p = 0;
  for (const PositionalSpec& spec : command.positionals) {
    if (p == positionalTexts.size()) {
      if (spec.optional) break;
      throw UsageError(spec.name, "\"" + commandName + "\" needs " + spec.name + " (" +
                                      spec.help + ")", commandName);
    }
    try {
      inv.positionals.push_back(
          parseValue(spec.kind, positionalTexts[p], spec.name, spec.bounds, {}));
    } catch (const UsageError& e) {
      throw UsageError(e.argument(), e.what(), commandName);
    }
    ++p;
  }
  if (p < positionalTexts.size()) {
    throw UsageError(positionalTexts[p],
                     "unexpected argument \"" + positionalTexts[p] + "\" for \"" + commandName + "\"",
                     commandName);
  }
  for (const OptionSpec& o : command.options) {
    if (o.required && inv.options.count(o.name) == 0) {
      std::string shown = o.shortName != 0 ? std::string("-") + o.shortName : "--" + o.name;
      throw UsageError(shown, "\"" + commandName + "\" needs " + shown + " " + metavarOf(o),
                       commandName);
    }
  }
  if (command.check) {
    try {
      command.check(inv);
    } catch (const UsageError& e) {
      throw UsageError(e.argument(), e.what(), commandName);
    }
  }
  return inv;
}

std::string commandHelp(const CommandSpec& command) {
  std::ostringstream out;
  out << "usage: myriad " << command.name;
  for (const PositionalSpec& p : command.positionals) {
    out << (p.optional ? " [" + p.name + "]" : " " + p.name);
  }
  for (const OptionSpec& o : command.options) {
    std::string flag = o.shortName != 0 ? std::string("-") + o.shortName : "--" + o.name;
    std::string meta = metavarOf(o);
    std::string text = flag + (meta.empty() ? "" : " " + meta);
    out << (o.required ? " " + text : " [" + text + "]");
  }
  out << "\n\n" << command.summary << "\n";
  if (!command.positionals.empty() || !command.options.empty()) out << "\n";
  auto line = [&](const std::string& left, const std::string& help) {
    out << "  " << left;
    if (left.size() < 24) {
      out << std::string(24 - left.size(), ' ');
    } else {
      out << "\n" << std::string(26, ' ');
    }
    out << help << "\n";
  };
  for (const PositionalSpec& p : command.positionals) line(p.name, p.help);
  for (const OptionSpec& o : command.options) {
    std::string flag = o.shortName != 0 ? std::string("-") + o.shortName : "";
    std::string meta = metavarOf(o);
    std::string left = flag.empty() ? optionDisplayName(o) : flag;
    if (!meta.empty()) left += " " + meta;
    std::string help = o.help;
    if (o.bounds) help += " (" + describeBounds(*o.bounds) + ")";
    line(left, help);
  }
  if (!command.notes.empty()) out << "\n" << command.notes << "\n";
  out << "\nGlobal options: --server URL, --session-file PATH, --if-match ETAG, --json, -h/--help"
         " (see myriad --help).\n";
  return out.str();
}

std::string overviewHelp() {
  std::ostringstream out;
  out << "usage: myriad [--server URL] [--session-file PATH] [--if-match ETAG] [--json] COMMAND "
         "[ARGS]\n\n"
         "The command-line client of myriad-server: sessions, models, assets and objects, camera,\n"
         "lights, frames.\n\n"
         "Commands:\n";
  for (const CommandSpec& c : commandSpecs()) {
    std::string left = c.name;
    for (const PositionalSpec& p : c.positionals) left += p.optional ? " [" + p.name + "]" : " " + p.name;
    out << "  " << left << std::string(left.size() < 22 ? 22 - left.size() : 1, ' ') << c.summary
        << "\n";
  }
  out << "\nGlobal options:\n"
         "  --server URL            the server (env MYRIAD_SERVER, default http://127.0.0.1:8080)\n"
         "  --session-file PATH     where `session new` keeps id:token (default\n"
         "                          $XDG_STATE_HOME/myriad/session or ~/.local/state/myriad/session);\n"
         "                          env MYRIAD_SESSION=id:token wins over the file\n"
         "  --if-match ETAG         edit only while the session is at that version (its ETag,\n"
         "                          the ETag header of any of its answers, e.g. curl -i);\n"
         "                          else the server refuses (412) and nothing changes\n"
         "  --json                  print the server's JSON responses as they come\n"
         "  -h, --help              help (after a command: that command's help;\n"
         "                          `myriad help COMMAND` says the same)\n"
         "  --version               the client's version and the protocol it speaks\n"
         "\nExit status: 0 done, 1 the server refused or could not be reached, 2 bad usage.\n";
  return out.str();
}

}  // namespace myriad::cli

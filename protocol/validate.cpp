#include "protocol/validate.h"

#include <cmath>
#include <regex>
#include <set>
#include <stdexcept>
#include <unordered_map>

#include "protocol/schema_bundle.h"

namespace myriad::protocol {
namespace {

using nlohmann::json;

// The keywords validate() understands; anything else in a schema is a mistake in the schema (or a
// keyword this validator should learn), so it is refused up front rather than silently ignored.
const std::set<std::string, std::less<>> kAssertions = {
    "$ref",      "type",      "const",     "enum",     "minimum",  "maximum",
    "exclusiveMinimum",       "exclusiveMaximum",      "minLength", "maxLength",
    "pattern",   "minItems",  "maxItems",  "items",    "properties", "required",
    "additionalProperties"};
const std::set<std::string, std::less<>> kAnnotations = {
    "$schema", "$id", "$defs", "$comment", "title", "description", "default", "examples"};

// "defs.schema.json#/$defs/vec3" -> the defs schema's node; "#/..." stays in `doc`.
std::pair<std::string_view, const json*> resolveRef(std::string_view doc, const std::string& ref) {
  size_t hash = ref.find('#');
  std::string file = ref.substr(0, hash);
  std::string fragment = hash == std::string::npos ? "" : ref.substr(hash + 1);
  std::string_view refDoc = doc;
  if (!file.empty()) {
    constexpr std::string_view kSuffix = ".schema.json";
    std::string_view name = file;
    if (name.size() <= kSuffix.size() || name.substr(name.size() - kSuffix.size()) != kSuffix) {
      throw std::logic_error("protocol: $ref \"" + ref + "\" does not name a *.schema.json file");
    }
    name.remove_suffix(kSuffix.size());
    refDoc = {};
    for (std::string_view known : schemaNames()) {
      if (known == name) refDoc = known;  // a view into the embedded bundle, which lives forever
    }
    if (refDoc.empty()) throw std::logic_error("protocol: $ref to unknown schema \"" + ref + "\"");
  }
  return {refDoc, &schema(refDoc).at(json::json_pointer(fragment))};
}

// What a $ref node points to: its schema's name (for the "#/..." refs inside it) and the node.
struct RefTarget {
  std::string_view doc;
  const json* node;
};
using RefTable = std::unordered_map<const json*, RefTarget>;

// Walks a schema: refuses keywords validate() does not understand (a mistake in the schema, or a
// keyword this validator should learn, rather than a rule silently ignored), and resolves every
// $ref once, so validation is a table look-up per reference.
void compile(const json& node, std::string_view doc, const std::string& where, RefTable& refs) {
  if (!node.is_object()) throw std::logic_error("protocol: schema node " + where + " is not an object");
  for (const auto& [key, value] : node.items()) {
    if (!kAssertions.count(key) && !kAnnotations.count(key)) {
      throw std::logic_error("protocol: schema keyword \"" + key + "\" at " + where +
                             " is not supported by protocol/validate.cpp");
    }
  }
  if (node.contains("additionalProperties") && node["additionalProperties"] != json(false)) {
    throw std::logic_error("protocol: only additionalProperties: false is supported (" + where + ")");
  }
  if (auto it = node.find("$ref"); it != node.end()) {
    auto [refDoc, target] = resolveRef(doc, it->get<std::string>());
    refs[&node] = {refDoc, target};
  }
  if (auto it = node.find("properties"); it != node.end()) {
    for (const auto& [key, sub] : it->items()) compile(sub, doc, where + "/properties/" + key, refs);
  }
  if (auto it = node.find("$defs"); it != node.end()) {
    for (const auto& [key, sub] : it->items()) compile(sub, doc, where + "/$defs/" + key, refs);
  }
  if (auto it = node.find("items"); it != node.end()) compile(*it, doc, where + "/items", refs);
}

// Built on first use, read-only afterwards: safe to share between the server's threads.
const RefTable& refTable() {
  static const RefTable table = [] {
    RefTable refs;
    for (std::string_view name : schemaNames()) compile(schema(name), name, std::string(name), refs);
    return refs;
  }();
  return table;
}

std::string escapePointerToken(std::string_view token) {
  std::string out;
  for (char c : token) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}

// How a message names the member at `pointer`: "eye/1" in quotes, or "The body" (it starts the sentence).
std::string memberName(const std::string& pointer) {
  if (pointer.empty()) return "The body";
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) about "literal" + std::string.
  std::string name(1, '"');
  name.append(pointer, 1);
  name += '"';
  return name;
}

// Client text quoted in a message: shortened, so a huge value cannot make a huge error.
std::string quoted(const json& value) {
  std::string text = value.dump(-1, ' ', false, json::error_handler_t::replace);
  constexpr size_t kMax = 60;
  if (text.size() <= kMax) return text;
  size_t cut = kMax;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;  // whole UTF-8 characters
  return text.substr(0, cut) + "...";
}

bool isWholeNumber(const json& v) {
  if (v.is_number_integer()) return true;
  if (!v.is_number_float()) return false;
  double d = v.get<double>();
  return std::isfinite(d) && std::floor(d) == d;
}

bool hasType(const json& v, std::string_view type) {
  if (type == "object") return v.is_object();
  if (type == "array") return v.is_array();
  if (type == "string") return v.is_string();
  if (type == "number") return v.is_number();
  if (type == "integer") return isWholeNumber(v);
  if (type == "boolean") return v.is_boolean();
  if (type == "null") return v.is_null();
  throw std::logic_error("protocol: unknown schema type \"" + std::string(type) + "\"");
}

std::string typeWords(std::string_view type) {
  if (type == "object") return "an object";
  if (type == "array") return "an array";
  if (type == "string") return "a string";
  if (type == "number") return "a number";
  if (type == "integer") return "a whole number";
  if (type == "boolean") return "true or false";
  return "null";
}

std::string describe(const json& v) {
  if (v.is_object()) return "an object";
  if (v.is_array()) return "an array";
  if (v.is_string()) return "the string " + quoted(v);
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_null()) return "null";
  return quoted(v);
}

// Length in Unicode code points, as JSON Schema counts: every byte but UTF-8 continuation bytes.
size_t codePoints(const std::string& s) {
  size_t n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return n;
}

std::string joinKeys(const json& properties) {
  std::string out;
  for (const auto& [key, value] : properties.items()) {
    (void)value;
    out += (out.empty() ? "" : ", ") + key;
  }
  return out;
}

class Validator {
 public:
  std::optional<ValidationError> check(const json& node, std::string_view doc, const json& value) {
    if (node.contains("$ref")) {
      const RefTarget& target = refs_.at(&node);
      if (auto error = check(*target.node, target.doc, value)) return error;
    }
    if (auto it = node.find("type"); it != node.end()) {
      if (auto error = checkType(*it, value)) return error;
    }
    if (auto it = node.find("const"); it != node.end() && value != *it) {
      return fail(memberName(pointer_) + " must be " + it->dump() + ", got " + describe(value) + ".");
    }
    if (auto it = node.find("enum"); it != node.end()) {
      bool found = false;
      std::string choices;
      for (const json& choice : *it) {
        found = found || choice == value;
        choices += (choices.empty() ? "" : ", ") + choice.dump();
      }
      if (!found) {
        return fail(memberName(pointer_) + " must be one of " + choices + "; got " + describe(value) + ".");
      }
    }
    if (value.is_number()) return checkNumber(node, value);
    if (value.is_string()) return checkString(node, value.get_ref<const std::string&>());
    if (value.is_array()) return checkArray(node, doc, value);
    if (value.is_object()) return checkObject(node, doc, value);
    return std::nullopt;
  }

 private:
  const RefTable& refs_ = refTable();
  std::string pointer_;

  ValidationError failure(std::string message) const { return {pointer_, std::move(message)}; }
  std::optional<ValidationError> fail(std::string message) const { return failure(std::move(message)); }

  std::optional<ValidationError> checkType(const json& type, const json& value) {
    if (type.is_string()) {
      if (hasType(value, type.get<std::string>())) return std::nullopt;
      return fail(memberName(pointer_) + " must be " + typeWords(type.get<std::string>()) + ", got " +
                  describe(value) + ".");
    }
    std::string words;
    for (const json& t : type) {
      if (hasType(value, t.get<std::string>())) return std::nullopt;
      words += (words.empty() ? "" : " or ") + typeWords(t.get<std::string>());
    }
    return fail(memberName(pointer_) + " must be " + words + ", got " + describe(value) + ".");
  }

  std::optional<ValidationError> checkNumber(const json& node, const json& value) {
    double v = value.get<double>();
    if (!std::isfinite(v)) return fail(memberName(pointer_) + " must be a finite number.");
    auto bound = [&](const char* keyword, auto outside, const char* rule) -> std::optional<ValidationError> {
      auto it = node.find(keyword);
      if (it == node.end() || !outside(v, it->template get<double>())) return std::nullopt;
      return fail(memberName(pointer_) + " must be " + rule + " " + it->dump() + ", got " + quoted(value) + ".");
    };
    if (auto e = bound("minimum", [](double x, double m) { return x < m; }, "at least")) return e;
    if (auto e = bound("exclusiveMinimum", [](double x, double m) { return x <= m; }, "greater than")) return e;
    if (auto e = bound("maximum", [](double x, double m) { return x > m; }, "at most")) return e;
    if (auto e = bound("exclusiveMaximum", [](double x, double m) { return x >= m; }, "less than")) return e;
    return std::nullopt;
  }

  std::optional<ValidationError> checkString(const json& node, const std::string& s) {
    size_t length = codePoints(s);
    if (auto it = node.find("minLength"); it != node.end() && length < it->get<size_t>()) {
      return fail(memberName(pointer_) + " must be at least " + it->dump() + " characters long.");
    }
    if (auto it = node.find("maxLength"); it != node.end() && length > it->get<size_t>()) {
      return fail(memberName(pointer_) + " must be at most " + it->dump() + " characters long.");
    }
    if (auto it = node.find("pattern"); it != node.end()) {
      // JSON Schema patterns are ECMA-262 and unanchored, like std::regex_search's default.
      std::regex re(it->get<std::string>(), std::regex::ECMAScript);
      if (!std::regex_search(s, re)) {
        return fail(memberName(pointer_) + " must match " + it->get<std::string>() + ", got " +
                    quoted(json(s)) + ".");
      }
    }
    return std::nullopt;
  }

  std::optional<ValidationError> checkArray(const json& node, std::string_view doc, const json& array) {
    auto minItems = node.find("minItems");
    auto maxItems = node.find("maxItems");
    size_t n = array.size();
    bool tooFew = minItems != node.end() && n < minItems->get<size_t>();
    bool tooMany = maxItems != node.end() && n > maxItems->get<size_t>();
    if (tooFew || tooMany) {
      std::string rule;
      if (minItems != node.end() && maxItems != node.end() && *minItems == *maxItems) {
        rule = "exactly " + minItems->dump();
      } else if (tooFew) {
        rule = "at least " + minItems->dump();
      } else {
        rule = "at most " + maxItems->dump();
      }
      return fail(memberName(pointer_) + " must have " + rule + " items, got " + std::to_string(n) + ".");
    }
    if (auto items = node.find("items"); items != node.end()) {
      size_t length = pointer_.size();
      for (size_t i = 0; i < n; ++i) {
        pointer_ += '/';
        pointer_ += std::to_string(i);
        if (auto error = check(*items, doc, array[i])) return error;
        pointer_.resize(length);
      }
    }
    return std::nullopt;
  }

  std::optional<ValidationError> checkObject(const json& node, std::string_view doc, const json& object) {
    static const json kNoProperties = json::object();
    auto propertiesIt = node.find("properties");
    const json& properties = propertiesIt != node.end() ? *propertiesIt : kNoProperties;
    size_t length = pointer_.size();
    if (node.contains("additionalProperties")) {  // always false (see compile())
      for (const auto& [key, value] : object.items()) {
        (void)value;
        if (properties.contains(key)) continue;
        std::string where = pointer_.empty() ? "the body" : memberName(pointer_);
        pointer_ += '/';
        pointer_ += escapePointerToken(key);
        std::string allowed = properties.empty() ? "it takes no members" : "its members are " + joinKeys(properties);
        auto error = failure(memberName(pointer_) + " is not a member of " + where + "; " + allowed + ".");
        return error;
      }
    }
    if (auto required = node.find("required"); required != node.end()) {
      for (const json& key : *required) {
        if (object.contains(key.get<std::string>())) continue;
        pointer_ += '/';
        pointer_ += escapePointerToken(key.get<std::string>());
        return failure(memberName(pointer_) + " is required.");
      }
    }
    for (const auto& [key, sub] : properties.items()) {
      auto it = object.find(key);
      if (it == object.end()) continue;
      pointer_ += '/';
      pointer_ += escapePointerToken(key);
      if (auto error = check(sub, doc, *it)) return error;
      pointer_.resize(length);
    }
    return std::nullopt;
  }
};

std::optional<ValidationError> memberError(std::string pointer, std::string message) {
  return ValidationError{std::move(pointer), std::move(message)};
}

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

}  // namespace

std::optional<ValidationError> validate(std::string_view schemaName, const nlohmann::json& body) {
  const json& root = schema(schemaName);  // throws for an unknown name
  Validator validator;
  for (std::string_view name : schemaNames()) {
    if (name == schemaName) return validator.check(root, name, body);
  }
  return std::nullopt;  // unreachable: schema() threw
}

ParsedBody parseBody(std::string_view schemaName, std::string_view text) {
  ParsedBody result;
  if (text.empty()) {
    result.error = ValidationError{"", "The body is empty; it must be a JSON object."};
    return result;
  }
  try {
    result.json = json::parse(text);
  } catch (const json::parse_error& e) {
    result.json = nullptr;
    result.error = ValidationError{"", std::string("The body is not valid JSON: ") + e.what() + "."};
    return result;
  } catch (const json::exception& e) {  // out_of_range: a number such as 1e400 overflows a double
    result.json = nullptr;
    result.error = ValidationError{"", std::string("The body holds a number out of range: ") + e.what() + "."};
    return result;
  }
  result.error = validate(schemaName, result.json);
  return result;
}

std::optional<ValidationError> checkCamera(const Camera& c) {
  if (!(c.far > c.near)) {
    return memberError("/far", "\"far\" must be greater than \"near\".");
  }
  Vec3 view = sub(c.target, c.eye);
  double viewLength2 = dot(view, view);
  if (viewLength2 == 0) {
    return memberError("/target", "\"target\" must differ from \"eye\".");
  }
  double upLength2 = dot(c.up, c.up);
  if (upLength2 == 0) {
    return memberError("/up", "\"up\" must not be [0, 0, 0].");
  }
  // Parallel when the sine of the angle between them is tiny (relative, so scale does not matter).
  Vec3 c3 = cross(view, c.up);
  if (dot(c3, c3) <= 1e-12 * viewLength2 * upLength2) {
    return memberError("/up", "\"up\" must not be parallel to the view direction (target - eye).");
  }
  return std::nullopt;
}

std::optional<ValidationError> checkSunDirection(const Vec3& d) {
  if (dot(d, d) == 0) return memberError("/sun/direction", "\"sun/direction\" must not be [0, 0, 0].");
  return std::nullopt;
}

std::optional<ValidationError> checkBounds(const Bounds& b, std::string_view pointer) {
  for (int i = 0; i < 3; ++i) {
    if (b.min[i] > b.max[i]) {
      std::string p = std::string(pointer) + "/max/" + std::to_string(i);
      return memberError(p, "\"" + p.substr(1) + "\" must not be less than \"" + std::string(pointer.substr(1)) +
                                "/min/" + std::to_string(i) + "\".");
    }
  }
  return std::nullopt;
}

std::optional<ValidationError> checkLight(const Light& l, bool blameOuter) {
  if (dot(l.direction, l.direction) == 0) {
    return memberError("/direction", "\"direction\" must not be [0, 0, 0].");
  }
  if (!(l.innerConeAngle < l.outerConeAngle)) {
    if (blameOuter) {
      return memberError("/outerConeAngle", "\"outerConeAngle\" must be greater than \"innerConeAngle\" (" +
                                                 std::to_string(l.innerConeAngle) + ").");
    }
    return memberError("/innerConeAngle", "\"innerConeAngle\" must be less than \"outerConeAngle\" (" +
                                               std::to_string(l.outerConeAngle) + ").");
  }
  return std::nullopt;
}

std::optional<ValidationError> checkLightsGenerate(const LightsGenerate& r) {
  if (r.bounds) {
    if (auto error = checkBounds(*r.bounds, "/bounds")) return error;
  }
  if (r.radius && r.radius->min > r.radius->max) {
    return memberError("/radius/1", "\"radius/1\" (the largest radius) must not be less than \"radius/0\".");
  }
  if (r.intensity && r.intensity->min > r.intensity->max) {
    return memberError("/intensity/1",
                       "\"intensity/1\" (the largest intensity) must not be less than \"intensity/0\".");
  }
  return std::nullopt;
}

}  // namespace myriad::protocol

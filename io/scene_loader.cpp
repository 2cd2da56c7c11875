// Scene loading: YAML text -> SceneSpec, driven by the schema table (io/schema_table.h).
//
//   text ──YAML::Load──► tree ──apply --set overrides──► tree ──readMap (schema walk)──► SceneSpec
//                                                                     │
//                                   cross-field checks (domain, blocks, inflows, phases)
//
// Every problem becomes an InputIssue "file:line:col: message" (1-based; yaml-cpp marks are
// 0-based). Nothing stops at the first problem: all of them are collected, sorted by position and
// thrown as one InputError. Problems in values that came from `--set` are reported against the
// file "--set" and quote the override, since they have no place in the scene file.
#include "io/scene_loader.h"

#include "core/errors.h"
#include "core/implicit_viscosity.h"
#include "io/obj_io.h"
#include "io/schema_table.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

namespace sph::io {

namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------------------------
// Small helpers: positions, paths, suggestions, value descriptions
// ---------------------------------------------------------------------------------------------

/// yaml-cpp marks are 0-based and -1 when unknown; InputIssue wants 1-based and 0 when unknown.
int lineOf(const YAML::Mark& mark) { return mark.line < 0 ? 0 : mark.line + 1; }
int colOf(const YAML::Mark& mark) { return mark.line < 0 || mark.column < 0 ? 0 : mark.column + 1; }

std::string join(const std::string& prefix, const std::string& name) {
  return prefix.empty() ? name : prefix + "." + name;
}

std::string indexed(const std::string& path, std::size_t i) { return path + "[" + std::to_string(i) + "]"; }

/// Optimal string alignment distance (Levenshtein plus adjacent transpositions).
std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i)
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[a.size()][b.size()];
}

/// The closest candidate to `word` when it is close enough to be a likely typo, else "".
std::string closest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = std::string::npos;
  for (const auto& candidate : candidates) {
    const std::size_t distance = editDistance(word, candidate);
    const std::size_t allowed = std::max<std::size_t>(2, candidate.size() / 3);
    if (distance <= allowed && distance < candidate.size() && distance < best_distance) {
      best = candidate;
      best_distance = distance;
    }
  }
  return best;
}

std::string didYouMean(const std::string& suggestion) {
  return suggestion.empty() ? std::string() : " (did you mean '" + suggestion + "'?)";
}

std::string joinList(const std::vector<std::string>& items, const char* separator = ", ") {
  std::string s;
  for (const auto& item : items) s += (s.empty() ? "" : separator) + item;
  return s;
}

std::vector<std::string> childNames(const std::string& schema_parent) {
  std::vector<std::string> names;
  for (const KeyDef* key : childKeys(schema_parent)) names.push_back(key->name());
  return names;
}

/// How a value that has the wrong type looks, for "got ..." in messages.
std::string describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "nothing";
  if (node.IsMap()) return "a map";
  if (node.IsSequence()) return "a list of " + std::to_string(node.size()) + " item(s)";
  if (node.Tag() == "!") return "the quoted string \"" + node.Scalar() + "\"";
  return "'" + node.Scalar() + "'";
}

std::string vecText(const Eigen::Vector3d& v) { return valueText(Value(v)); }

/// What a key's type expects, for "must be ..." in messages.
std::string expectation(const KeyDef& key) {
  std::string what;
  switch (key.type) {
    case KeyType::Float: what = "a number"; break;
    case KeyType::Int: what = "an integer"; break;
    case KeyType::Bool: what = "true or false"; break;
    case KeyType::String: what = "a string"; break;
    case KeyType::Enum: what = "one of: " + joinList(key.choices); break;
    case KeyType::Vec3: what = "a list of 3 numbers [x, y, z]"; break;
    case KeyType::Map: what = "a map with keys " + joinList(childNames(key.path)); break;
    case KeyType::List: what = "a list of maps with keys " + joinList(childNames(key.path + "[]")); break;
  }
  if (!key.unit.empty() && key.unit != "1") what += " (unit: " + key.unit + ")";
  return what;
}

/// A plain (unquoted) YAML scalar read as a double: "1.5", "-2e-3", ".inf", "-.Inf", ".nan".
std::optional<double> readNumber(const YAML::Node& node) {
  if (!node.IsScalar() || node.Tag() == "!") return std::nullopt;
  std::string text = node.Scalar();
  if (text.empty()) return std::nullopt;
  // YAML 1.2 spells infinity and NaN with a leading dot; strtod does not.
  std::string bare = text;
  if (bare[0] == '+' || bare[0] == '-') bare = bare.substr(1);
  if (bare == ".inf" || bare == ".Inf" || bare == ".INF")
    return text[0] == '-' ? -HUGE_VAL : HUGE_VAL;
  if (bare == ".nan" || bare == ".NaN" || bare == ".NAN") return std::nan("");
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size()) return std::nullopt;
  return v;
}

/// A plain YAML scalar read as a decimal integer.
std::optional<long> readInteger(const YAML::Node& node) {
  if (!node.IsScalar() || node.Tag() == "!") return std::nullopt;
  const std::string text = node.Scalar();
  if (text.empty()) return std::nullopt;
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || errno == ERANGE) return std::nullopt;
  return v;
}

// ---------------------------------------------------------------------------------------------
// --set overrides: "key.path=value", e.g. "fluid.phases[0].viscosity=1e-3"
// ---------------------------------------------------------------------------------------------

struct Override {
  struct Segment {
    std::string name;
    long index = -1;  ///< list index, -1 when the segment is not indexed
  };
  std::string text;                ///< as given, for messages
  std::string path;                ///< normalised concrete path, "fluid.phases[0].viscosity"
  std::vector<Segment> segments;
  YAML::Node value;                ///< the value, parsed as YAML (scalar or flow)
};

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

/// Parses and checks one override against the schema. Adds an issue (file "--set") and returns
/// nullopt when the key is malformed or unknown, or the value is not valid YAML.
std::optional<Override> parseOverride(const std::string& text, std::vector<InputIssue>& issues) {
  auto fail = [&](const std::string& message) {
    issues.push_back({"--set", 0, 0, "'" + text + "': " + message});
    return std::nullopt;
  };
  Override ov;
  ov.text = text;
  const auto eq = text.find('=');
  if (eq == std::string::npos) return fail("expected key.path=value");
  const std::string key = trim(text.substr(0, eq));

  // Split "a.b[2].c" into segments {a}, {b, 2}, {c}.
  std::stringstream parts(key);
  std::string part;
  while (std::getline(parts, part, '.')) {
    Override::Segment seg;
    const auto bracket = part.find('[');
    seg.name = part.substr(0, bracket);
    if (bracket != std::string::npos) {
      const std::string digits = part.substr(bracket + 1, part.size() - bracket - 2);
      const bool well_formed = part.back() == ']' && !digits.empty() &&
                               digits.find_first_not_of("0123456789") == std::string::npos;
      if (!well_formed || digits.size() > 9) return fail("malformed key '" + key + "' (items are addressed as fluid.phases[0].name)");
      seg.index = std::stol(digits);
    }
    if (seg.name.empty()) return fail("malformed key '" + key + "' (expected a dotted path such as simulation.duration)");
    ov.segments.push_back(seg);
  }
  if (ov.segments.empty() || key.back() == '.') return fail("malformed key '" + key + "'");

  // Walk the schema along the segments: every segment must exist, lists need an index (except
  // when the whole list is replaced), and leaves have no sub-keys.
  std::string schema_prefix, concrete;
  for (std::size_t k = 0; k < ov.segments.size(); ++k) {
    const auto& seg = ov.segments[k];
    const bool last = k + 1 == ov.segments.size();
    const KeyDef* def = findKey(join(schema_prefix, seg.name));
    if (!def) {
      std::string suggestion = closest(seg.name, childNames(schema_prefix));
      if (!suggestion.empty()) {
        // Suggest the whole corrected key, not just the misspelt segment.
        std::string full = join(concrete, suggestion);
        if (seg.index >= 0) full = indexed(full, static_cast<std::size_t>(seg.index));
        for (std::size_t r = k + 1; r < ov.segments.size(); ++r) {
          full = join(full, ov.segments[r].name);
          if (ov.segments[r].index >= 0) full = indexed(full, static_cast<std::size_t>(ov.segments[r].index));
        }
        suggestion = full;
      } else {
        const std::string where = schema_prefix.empty() ? "at the top level" : "in '" + concrete + "'";
        return fail("unknown key '" + key + "' (known keys " + where + ": " + joinList(childNames(schema_prefix)) + ")");
      }
      return fail("unknown key '" + key + "'" + didYouMean(suggestion));
    }
    concrete = join(concrete, seg.name);
    if (def->type == KeyType::List) {
      if (seg.index < 0 && !last) return fail("'" + concrete + "' is a list: address an item as " + concrete + "[0]");
      if (seg.index >= 0) concrete = indexed(concrete, static_cast<std::size_t>(seg.index));
      schema_prefix = def->path + "[]";
    } else {
      if (seg.index >= 0) return fail("'" + concrete + "' is not a list");
      if (def->isLeaf() && !last) return fail("'" + concrete + "' is a " + keyTypeName(def->type) + " and has no sub-keys");
      schema_prefix = def->path;
    }
  }
  ov.path = concrete;

  // The value is YAML, so "[0, 0, -1]" is a list and "1e-3" a number.
  try {
    ov.value = YAML::Load(text.substr(eq + 1));
  } catch (const YAML::Exception& e) {
    return fail("cannot parse the value as YAML: " + e.msg);
  }
  return ov;
}

/// Writes the override's value into the YAML tree, creating missing sections on the way. List
/// items must already exist in the scene. Returns false (with an issue) when the tree's shape
/// does not allow it, e.g. "simulation: 3" or an index past the end of the list.
bool applyOverride(YAML::Node& root, const Override& ov, std::vector<InputIssue>& issues) {
  auto fail = [&](const std::string& message) {
    issues.push_back({"--set", 0, 0, "'" + ov.text + "': " + message});
    return false;
  };
  if (root.IsNull() || !root.IsDefined()) root = YAML::Node(YAML::NodeType::Map);
  if (!root.IsMap()) return false;  // reported by the loader as "a scene must be a map"

  YAML::Node cur = root;  // yaml-cpp nodes are handles: cur.reset() re-points, operator= assigns content
  std::string path;
  for (std::size_t k = 0; k < ov.segments.size(); ++k) {
    const auto& seg = ov.segments[k];
    const bool last = k + 1 == ov.segments.size();
    if (!cur.IsMap()) return fail("cannot set it: '" + path + "' is " + describe(cur) + " in the scene, not a map");
    path = join(path, seg.name);
    if (seg.index < 0) {
      if (last) {
        cur[seg.name] = ov.value;
        break;
      }
      YAML::Node child = cur[seg.name];
      if (!child.IsDefined() || child.IsNull()) cur[seg.name] = YAML::Node(YAML::NodeType::Map);
      cur.reset(cur[seg.name]);
      continue;
    }
    // Indexed segment: the item must exist.
    YAML::Node list = cur[seg.name];
    const std::size_t size = list.IsDefined() && list.IsSequence() ? list.size() : 0;
    if (static_cast<std::size_t>(seg.index) >= size)
      return fail("'" + path + "' has " + std::to_string(size) + " item(s) in the scene, so index " +
                  std::to_string(seg.index) + " does not exist");
    path = indexed(path, static_cast<std::size_t>(seg.index));
    if (last) {
      list[static_cast<std::size_t>(seg.index)] = ov.value;
      break;
    }
    cur.reset(list[static_cast<std::size_t>(seg.index)]);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// The schema walk
// ---------------------------------------------------------------------------------------------

/// A name that is safe inside a file name: [A-Za-z0-9_.-]{1,64}, not starting with '.'.
bool safeFileName(const std::string& name) {
  if (name.empty() || name.size() > 64 || name[0] == '.') return false;
  for (const char c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.') return false;
  return true;
}

class Loader {
 public:
  /// `file` names the scene in messages; `anchor` (absolute, may be empty) is the scene file that
  /// relative paths inside it (meshes) are relative to.
  Loader(std::string file, fs::path anchor) : file_(std::move(file)), anchor_(std::move(anchor)) {}

  /// Parses, applies overrides, reads and checks. Throws InputError when anything is wrong.
  SceneSpec load(const std::string& text, const std::vector<std::string>& override_texts) {
    // Overrides are checked against the schema first: that needs no scene.
    std::vector<Override> overrides;
    for (const auto& text_item : override_texts)
      if (auto ov = parseOverride(text_item, issues_)) overrides.push_back(std::move(*ov));

    // Parse the YAML; a syntax error ends the reading, with its location.
    YAML::Node root;
    try {
      root = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      issues_.push_back({file_, lineOf(e.mark), colOf(e.mark), "YAML syntax error: " + e.msg});
      throwIssues();
    }

    // Apply the overrides onto the tree, so they are validated exactly like scene values.
    for (const auto& ov : overrides)
      if (applyOverride(root, ov, issues_)) overridden_[ov.path] = ov.text;

    // Walk the tree along the schema, then check what spans several keys.
    SceneSpec spec;
    if (root.IsNull() || !root.IsDefined()) {
      requireKeys("", "", {}, YAML::Mark::null_mark());
    } else if (!root.IsMap()) {
      issue("", root.Mark(), "a scene must be a map with the sections " + joinList(childNames("")) + ", got " + describe(root));
    } else {
      readMap(root, "", "", 0, spec, root.Mark());
    }
    crossCheck(spec);
    throwIssues();
    return spec;
  }

  /// The override that set `path` or one of its parents ("" when none).
  std::string overrideFor(const std::string& path) const {
    for (const auto& [p, text] : overridden_) {
      if (path == p) return text;
      if (path.size() > p.size() && path.compare(0, p.size(), p) == 0 && (path[p.size()] == '.' || path[p.size()] == '['))
        return text;
    }
    return "";
  }

 private:
  // --- issues --------------------------------------------------------------------------------

  /// Records a problem with the value at concrete path `path`, located at `mark` in the file, or
  /// against "--set" when the value came from an override.
  void issue(const std::string& path, const YAML::Mark& mark, const std::string& message) {
    const std::string from_override = overrideFor(path);
    if (!from_override.empty())
      issues_.push_back({"--set", 0, 0, "'" + from_override + "': " + message});
    else
      issues_.push_back({file_, lineOf(mark), colOf(mark), message});
    bad_.insert(path);
  }

  void throwIssues() {
    if (issues_.empty()) return;
    std::stable_sort(issues_.begin(), issues_.end(), [](const InputIssue& a, const InputIssue& b) {
      return a.line != b.line ? a.line < b.line : a.col < b.col;
    });
    throw InputError(issues_);
  }

  SourceLoc locAt(const std::string& path, const YAML::Mark& mark) const {
    if (!overrideFor(path).empty()) return SourceLoc{"--set", 0, 0};
    return SourceLoc{file_, lineOf(mark), colOf(mark)};
  }

  /// The recorded position of `path`, or of its nearest recorded parent.
  YAML::Mark markOf(std::string path) const {
    while (!path.empty()) {
      if (auto it = marks_.find(path); it != marks_.end()) return it->second;
      const auto cut = path.find_last_of(".[");
      path = cut == std::string::npos ? "" : path.substr(0, cut);
    }
    return YAML::Mark::null_mark();
  }

  bool given(const std::string& path) const { return marks_.count(path) && !bad_.count(path); }
  bool usable(const std::string& path) const { return !bad_.count(path); }

  // --- reading -------------------------------------------------------------------------------

  /// Reads the keys of one YAML map: a section (schema_prefix "fluid"), a list item
  /// ("fluid.phases[]", with `index`) or the top level (""). `where` locates the map itself.
  void readMap(const YAML::Node& map, const std::string& schema_prefix, const std::string& path_prefix,
               std::size_t index, SceneSpec& spec, const YAML::Mark& where) {
    std::map<std::string, YAML::Mark> seen;  // key name -> where it was given
    for (auto it = map.begin(); it != map.end(); ++it) {
      // Copies, not references: the iterator's -> yields a temporary proxy (Nodes are handles).
      const YAML::Node key_node = it->first;
      const YAML::Node value = it->second;
      if (!key_node.IsScalar()) {
        issue(path_prefix, key_node.Mark(), "keys must be plain names, got " + describe(key_node));
        continue;
      }
      const std::string name = key_node.Scalar();
      const std::string path = join(path_prefix, name);

      // Duplicates: yaml-cpp keeps both; the scene would silently use the first.
      if (auto first = seen.find(name); first != seen.end()) {
        issue(path, key_node.Mark(),
              "duplicate key '" + name + "' (first given at line " + std::to_string(lineOf(first->second)) + ")");
        continue;
      }
      seen[name] = key_node.Mark();

      // Unknown key: suggest a sibling spelt alike, or say where the key does belong.
      const KeyDef* def = findKey(join(schema_prefix, name));
      if (!def) {
        issue(path, key_node.Mark(), unknownKeyMessage(name, schema_prefix, path_prefix));
        continue;
      }

      // A key written with nothing after it carries the next token's mark; use the key's.
      const YAML::Mark value_mark = value.IsNull() ? key_node.Mark() : value.Mark();
      switch (def->type) {
        case KeyType::Map: readSection(*def, key_node.Mark(), value, path, index, spec); break;
        case KeyType::List: readList(*def, value, value_mark, path, index, spec); break;
        default:
          marks_[path] = value_mark;
          readLeaf(*def, value, value_mark, path, index, spec);
          break;
      }
    }
    requireKeys(schema_prefix, path_prefix, seen, where);
  }

  std::string unknownKeyMessage(const std::string& name, const std::string& schema_prefix, const std::string& path_prefix) {
    const std::string where = path_prefix.empty() ? "at the top level" : "in '" + path_prefix + "'";
    const std::vector<std::string> siblings = childNames(schema_prefix);
    const std::string suggestion = closest(name, siblings);
    if (!suggestion.empty()) return "unknown key '" + name + "' " + where + didYouMean(suggestion);
    // The name may be right but in the wrong place (e.g. 'viscosity' directly under 'fluid').
    for (const KeyDef& key : schemaTable())
      if (key.name() == name) return "unknown key '" + name + "' " + where + " ('" + key.path + "' exists)";
    return "unknown key '" + name + "' " + where + " (known keys: " + joinList(siblings) + ")";
  }

  void readSection(const KeyDef& def, const YAML::Mark& key_mark, const YAML::Node& value, const std::string& path,
                   std::size_t index, SceneSpec& spec) {
    marks_[path] = key_mark;
    if (def.loc) *def.loc(spec, index) = locAt(path, key_mark);
    if (value.IsNull()) {  // "simulation:" with nothing in it: all defaults
      requireKeys(def.path, path, {}, key_mark);
      return;
    }
    if (!value.IsMap()) {
      issue(path, value.Mark(), "'" + path + "' must be " + expectation(def) + ", got " + describe(value));
      return;
    }
    readMap(value, def.path, path, index, spec, key_mark);
  }

  /// `parent` is the index of the list item that holds this list (0 at the top level).
  void readList(const KeyDef& def, const YAML::Node& value, const YAML::Mark& value_mark, const std::string& path,
                std::size_t parent, SceneSpec& spec) {
    if (value.IsNull()) return;  // "phases:" with nothing: as if absent
    marks_[path] = value_mark;
    if (!value.IsSequence()) {
      issue(path, value_mark, "'" + path + "' must be " + expectation(def) + ", got " + describe(value));
      return;
    }
    def.resize(spec, parent, value.size());
    for (std::size_t i = 0; i < value.size(); ++i) {
      const YAML::Node item = value[i];
      const std::string item_path = indexed(path, i);
      const YAML::Mark item_mark = item.IsNull() ? value_mark : item.Mark();
      const std::size_t item_index = def.item_index(parent, i);
      marks_[item_path] = item_mark;
      *def.loc(spec, item_index) = locAt(item_path, item_mark);
      if (!item.IsMap()) {
        issue(item_path, item_mark,
              "each item of '" + path + "' must be a map with keys " + joinList(childNames(def.path + "[]")) +
                  ", got " + describe(item));
        continue;
      }
      readMap(item, def.path + "[]", item_path, item_index, spec, item_mark);
    }
  }

  /// Reports missing required keys under a map; recurses into absent sections (their required
  /// keys are missing too). Problems are located at the map (`where`).
  void requireKeys(const std::string& schema_prefix, const std::string& path_prefix,
                   const std::map<std::string, YAML::Mark>& seen, const YAML::Mark& where) {
    for (const KeyDef* key : childKeys(schema_prefix)) {
      const std::string name = key->name();
      if (seen.count(name)) continue;
      const std::string path = join(path_prefix, name);
      if (key->required)
        issue(path, where, "missing required key '" + path + "'" + (key->unit.empty() ? "" : " (" + expectation(*key) + ")"));
      else if (key->type == KeyType::Map)
        requireKeys(key->path, path, {}, where);
    }
  }

  /// Reads, checks and stores one leaf value.
  void readLeaf(const KeyDef& def, const YAML::Node& node, const YAML::Mark& mark, const std::string& path,
                std::size_t index, SceneSpec& spec) {
    auto wrongType = [&]() { issue(path, mark, "'" + path + "' must be " + expectation(def) + ", got " + describe(node)); };
    std::optional<Value> value;

    switch (def.type) {
      case KeyType::Float: {
        const auto v = readNumber(node);
        if (!v || std::isnan(*v)) return wrongType();
        if (!checkNumber(def, *v, path, path, mark)) return;
        value = *v;
        break;
      }
      case KeyType::Int: {
        const auto v = readInteger(node);
        if (!v) return wrongType();
        if (!checkNumber(def, static_cast<double>(*v), path, path, mark)) return;
        value = *v;
        break;
      }
      case KeyType::Bool: {
        bool b = false;
        if (!node.IsScalar() || node.Tag() == "!" || !YAML::convert<bool>::decode(node, b)) return wrongType();
        value = b;
        break;
      }
      case KeyType::String: {
        if (!node.IsScalar()) return wrongType();
        value = node.Scalar();
        break;
      }
      case KeyType::Enum: {
        if (!node.IsScalar()) return wrongType();
        const std::string& text = node.Scalar();
        if (std::find(def.choices.begin(), def.choices.end(), text) == def.choices.end()) {
          issue(path, mark,
                "'" + path + "' = '" + text + "' is not allowed (allowed values: " + joinList(def.choices) + ")" +
                    didYouMean(closest(text, def.choices)));
          return;
        }
        value = text;
        break;
      }
      case KeyType::Vec3: {
        if (!node.IsSequence() || node.size() != 3) return wrongType();
        Eigen::Vector3d v;
        bool ok = true;
        for (std::size_t c = 0; c < 3; ++c) {
          const YAML::Node component = node[c];
          const std::string component_path = indexed(path, c);
          const auto x = readNumber(component);
          if (!x || !std::isfinite(*x)) {
            issue(path, component.Mark(),
                  "'" + component_path + "' must be a finite number" + (def.unit.empty() || def.unit == "1" ? "" : " (unit: " + def.unit + ")") +
                      ", got " + describe(component));
            ok = false;
          } else if (!checkNumber(def, *x, path, component_path, component.Mark())) {
            ok = false;
          } else {
            v[static_cast<Eigen::Index>(c)] = *x;
          }
        }
        if (!ok) return;
        value = v;
        break;
      }
      case KeyType::Map:
      case KeyType::List: return;  // handled by readSection / readList
    }
    def.set(spec, index, *value);
  }

  /// Range and finiteness check; `shown` is the path used in the message (a vec3 component).
  bool checkNumber(const KeyDef& def, double v, const std::string& path, const std::string& shown, const YAML::Mark& mark) {
    if (std::isinf(v) && !def.allow_infinity) {
      issue(path, mark, "'" + shown + "' must be finite, got " + numberText(v));
      return false;
    }
    if (v > def.int_max) {
      issue(path, mark, "'" + shown + "' = " + numberText(v) + " is too large (at most " + numberText(def.int_max) + ")");
      return false;
    }
    if (!def.range.contains(v)) {
      const bool two_sided = !std::isinf(def.range.lo) && !std::isinf(def.range.hi);
      issue(path, mark,
            "'" + shown + "' = " + numberText(v) + " is out of range (must be " + (two_sided ? "in " : "") +
                def.range.str() + (def.unit.empty() || def.unit == "1" ? "" : ", unit: " + def.unit) + ")");
      return false;
    }
    return true;
  }

  // --- checks across keys ------------------------------------------------------------------

  void crossCheck(SceneSpec& spec) {
    FluidSpec& fluid = spec.fluid;

    // Duration: a run simulates whole frames, round(duration x frame_rate) >= 1 of them.
    if (given("simulation.duration") && usable("simulation.frame_rate") &&
        !(spec.simulation.duration * spec.simulation.frame_rate >= 0.5))
      issue("simulation.duration", markOf("simulation.duration"),
            "'simulation.duration' " + numberText(spec.simulation.duration) +
                " s is shorter than half a frame (1 / frame_rate = " + numberText(1.0 / spec.simulation.frame_rate) +
                " s): a run simulates whole frames");

    // output.isosurface: writing the section asks for the surface, unless it says enabled: false.
    if (marks_.count("output.isosurface") && !marks_.count("output.isosurface.enabled"))
      spec.output.isosurface.enabled = true;

    // haptics: the section turns the stage on; the offset defaults to the domain centre; path
    // segments and waypoints must make sense (haptics/trajectory.h).
    if (marks_.count("haptics")) checkHaptics(spec);

    // Domain: max > min in every component.
    const DomainSpec& domain = spec.domain;
    bool domain_ok = given("domain.min") && given("domain.max");
    if (domain_ok && !(domain.max.array() > domain.min.array()).all()) {
      issue("domain.max", markOf("domain.max"),
            "'domain.max' " + vecText(domain.max) + " must be greater than 'domain.min' " + vecText(domain.min) +
                " in every component");
      domain_ok = false;
    }
    auto insideDomain = [&](const Eigen::Vector3d& p) {
      return (p.array() >= domain.min.array()).all() && (p.array() <= domain.max.array()).all();
    };
    const std::string domain_text = vecText(domain.min) + " .. " + vecText(domain.max);

    // A settle before t = 0 ends at full gravity; a gravity ramp after it would take the load off the
    // settled fluid again (it would expand and fall back): one or the other.
    if (spec.simulation.settle_time > 0.0 && spec.simulation.gravity_ramp > 0.0 && !bad_.count("simulation.settle_time") &&
        !bad_.count("simulation.gravity_ramp")) {
      const std::string at = marks_.count("simulation.settle_time") ? "simulation.settle_time" : "simulation.gravity_ramp";
      issue(at, markOf(at),
            "'simulation.settle_time' and 'simulation.gravity_ramp' cannot both be set: the settle brings the fluid to "
            "rest under full gravity before t = 0, and a ramp after it would take the load off again (use one)");
    }

    // DFSPH iteration bounds: the most iterations no fewer than the least (reported at the max key,
    // or at the min key when only it was written).
    const DfsphSpec& dfsph = fluid.dfsph;
    auto checkIterations = [&](const char* min_key, const char* max_key, int lo, int hi) {
      if (hi >= lo || bad_.count(min_key) || bad_.count(max_key)) return;
      const std::string at = marks_.count(max_key) ? max_key : min_key;
      issue(at, markOf(at), "'" + std::string(max_key) + "' (" + std::to_string(hi) + ") must be at least '" +
                                std::string(min_key) + "' (" + std::to_string(lo) + ")");
    };
    checkIterations("fluid.dfsph.min_iterations", "fluid.dfsph.max_iterations", dfsph.min_iterations,
                    dfsph.max_iterations);
    checkIterations("fluid.dfsph.divergence_min_iterations", "fluid.dfsph.divergence_max_iterations",
                    dfsph.divergence_min_iterations, dfsph.divergence_max_iterations);

    // Implicit viscosity solves the laminar model's operator, in DFSPH's step.
    if (dfsph.viscosity_solve == ViscositySolve::Implicit && usable("fluid.dfsph.viscosity_solve")) {
      if (fluid.solver != FluidSolver::Dfsph && usable("fluid.solver"))
        issue("fluid.dfsph.viscosity_solve", markOf("fluid.dfsph.viscosity_solve"),
              "'fluid.dfsph.viscosity_solve: implicit' needs 'fluid.solver: dfsph' (WCSPH's step is bound by the "
              "speed of sound: use explicit)");
      else if (fluid.viscosity_model != ViscosityModel::Laminar && usable("fluid.viscosity_model"))
        issue("fluid.dfsph.viscosity_solve", markOf("fluid.dfsph.viscosity_solve"),
              "'fluid.dfsph.viscosity_solve: implicit' solves the laminar viscosity: set 'fluid.viscosity_model: "
              "laminar' (the artificial viscosity is explicit)");
      // What the solve needs of the scene's bodies (core/implicit_viscosity.h, with the measurements): free
      // bodies strongly coupled, and cloth and light soft bodies in XPBD substeps of at most 0.5 ms.
      if (implicitViscosityStaggeredBodies(spec) && usable("fluid.dfsph.body_coupling"))
        issue("fluid.dfsph.viscosity_solve", markOf("fluid.dfsph.viscosity_solve"),
              "'fluid.dfsph.viscosity_solve: implicit' moves free bodies in its solve only with "
              "'fluid.dfsph.body_coupling: strong' (staggered, a ball released into syrup shot off or blew up: "
              "docs/dfsph.md, session 38); use strong, or the explicit viscosity");
      if (const ImplicitViscosityLightBody light = implicitViscosityLightBody(spec)) {
        std::ostringstream t;
        if (light.cloth)
          t << "cloth '" << light.name << "'";
        else
          t << "soft body '" << light.name << "' (" << light.density << " kg/m^3, lighter than the liquid's "
            << light.liquid_density << ")";
        issue("fluid.dfsph.viscosity_solve", markOf("fluid.dfsph.viscosity_solve"),
              "'fluid.dfsph.viscosity_solve: implicit' takes cloth, and soft bodies lighter than the liquid, only "
              "with their xpbd step split into substeps of at most 0.5 ms: not " + t.str() +
                  ". In one step per fluid step, light sheets and soft bodies swung or blew up in viscous liquids "
                  "(docs/dfsph.md, session 38); leave 'max_time_step' out (automatic, which chooses them) or set it "
                  "to at most 0.0005, or use the explicit viscosity");
      }
    }

    // A background pressure pushes on every wall: with an open wall the fluid would be pushed out of the
    // domain (tried, session 35: at 1 kPa, 116 of a weightless box's 7,835 particles left through its
    // open top in 0.4 s), and DFSPH's pressures come from its solve, not from the equation of state.
    if (fluid.background_pressure > 0.0 && usable("fluid.background_pressure")) {
      static const char* kWalls[6] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
      std::string open, first;  // the open walls, and the first of them
      for (int w = 0; w < 6; ++w) {
        if (spec.domain.closed[static_cast<std::size_t>(w)]) continue;
        if (first.empty()) first = kWalls[w];
        open += std::string(open.empty() ? "" : ", ") + kWalls[w];
      }
      if (fluid.solver == FluidSolver::Dfsph && usable("fluid.solver")) {
        issue("fluid.background_pressure", markOf("fluid.background_pressure"),
              "'fluid.background_pressure' is a wcsph setting: with 'fluid.solver: dfsph' the pressures come from "
              "the solve (remove the key, or use solver wcsph)");
      } else if (!open.empty()) {
        issue("fluid.background_pressure", markOf("fluid.background_pressure"),
              "'fluid.background_pressure' needs every domain wall closed, or it pushes the fluid out of the "
              "domain; open: " + open + " (set domain.closed." + first + ": true)");
      }
    }

    // Phases: one default phase when none is defined; names present and unique.
    if (!marks_.count("fluid.phases")) {
      fluid.phases.assign(1, PhaseSpec{});
      fluid.phases[0].name = kDefaultPhaseName;
      fluid.phases[0].loc = fluid.loc;
    } else if (fluid.phases.empty() && usable("fluid.phases")) {
      issue("fluid.phases", markOf("fluid.phases"), "'fluid.phases' must define at least one phase");
    }
    std::vector<std::string> phase_names;
    bool phases_ok = !fluid.phases.empty();  // every phase readable: references can be checked
    for (std::size_t i = 0; i < fluid.phases.size(); ++i) {
      const std::string path = indexed("fluid.phases", i) + ".name";
      const std::string& name = fluid.phases[i].name;
      if (!usable(indexed("fluid.phases", i)) || !usable(path) || name.empty()) phases_ok = false;
      if (given(path)) {
        if (name.empty()) {
          issue(path, markOf(path), "'" + path + "' must not be empty");
        } else if (auto j = std::find(phase_names.begin(), phase_names.end(), name); j != phase_names.end()) {
          const auto first = static_cast<std::size_t>(j - phase_names.begin());
          issue(path, markOf(path), "duplicate phase name '" + name + "' (already the name of " + indexed("fluid.phases", first) + ")");
        }
      }
      phase_names.push_back(name);
    }

    // Blocks and inflows name a defined phase; without one they take the first phase.
    auto checkPhaseRef = [&](std::string& phase, const std::string& item_path) {
      const std::string path = item_path + ".phase";
      if (!marks_.count(path)) {
        if (!fluid.phases.empty()) phase = fluid.phases[0].name;
        return;
      }
      if (!usable(path) || !phases_ok) return;
      if (std::find(phase_names.begin(), phase_names.end(), phase) == phase_names.end())
        issue(path, markOf(path),
              "undefined phase '" + phase + "' (defined phases: " + joinList(phase_names) + ")" + didYouMean(closest(phase, phase_names)));
    };

    // Blocks: min < max, inside the domain.
    for (std::size_t i = 0; i < fluid.blocks.size(); ++i) {
      BlockSpec& block = fluid.blocks[i];
      const std::string item = indexed("fluid.blocks", i);
      if (!usable(item)) continue;
      checkPhaseRef(block.phase, item);
      if (!given(item + ".min") || !given(item + ".max")) continue;
      if (!(block.max.array() > block.min.array()).all()) {
        issue(item + ".max", markOf(item + ".max"),
              "'" + item + ".max' " + vecText(block.max) + " must be greater than '" + item + ".min' " + vecText(block.min) +
                  " in every component");
      } else if (domain_ok && !(insideDomain(block.min) && insideDomain(block.max))) {
        issue(item, markOf(item),
              "block " + item + " (" + vecText(block.min) + " .. " + vecText(block.max) + ") is not inside the domain (" +
                  domain_text + ")");
      }
    }

    // Inflows: nonzero direction, position inside the domain, stop after start.
    for (std::size_t i = 0; i < fluid.inflows.size(); ++i) {
      InflowSpec& inflow = fluid.inflows[i];
      const std::string item = indexed("fluid.inflows", i);
      if (!usable(item)) continue;
      checkPhaseRef(inflow.phase, item);
      if (usable(item + ".direction") && inflow.direction.norm() == 0.0)
        issue(item + ".direction", markOf(item + ".direction"), "'" + item + ".direction' must be nonzero");
      if (domain_ok && given(item + ".position") && !insideDomain(inflow.position))
        issue(item + ".position", markOf(item + ".position"),
              "'" + item + ".position' " + vecText(inflow.position) + " is outside the domain (" + domain_text + ")");
      if (usable(item + ".start") && usable(item + ".stop") && !(inflow.stop > inflow.start)) {
        const std::string at = marks_.count(item + ".stop") ? item + ".stop" : item + ".start";
        issue(at, markOf(at),
              "'" + item + ".stop' = " + numberText(inflow.stop) + " must be greater than '" + item +
                  ".start' = " + numberText(inflow.start));
      }
    }

    checkBodies(spec);
    checkProbes(spec);
    checkAnchorKeyframes(spec);
    for (std::size_t c = 0; c < spec.cloth.size(); ++c) {
      const std::string mesh_key = indexed("cloth", c) + ".mesh";
      if (!given(mesh_key) || spec.cloth[c].mesh.empty()) continue;
      spec.cloth[c].mesh_loc = locAt(mesh_key, markOf(mesh_key));
      loadClothMesh(spec.cloth[c], mesh_key, "cloth '" + spec.cloth[c].name + "'");
      // The rectangle's keys mean nothing for a mesh cloth: remembered for a warning.
      for (const char* k : {".width", ".length", ".resolution_x", ".resolution_y", ".shear_stiffness"}) {
        const std::string key = indexed("cloth", c) + k;
        if (marks_.count(key)) spec.cloth[c].unused_keys.push_back(locAt(key, markOf(key)).str() + ": '" + key + "'");
      }
    }
    // Soft bodies from a mesh: a closed one (the lattice's cells are those inside it).
    for (std::size_t b = 0; b < spec.soft_bodies.size(); ++b) {
      SoftBodySpec& body = spec.soft_bodies[b];
      const std::string axis_key = indexed("soft_bodies", b) + ".orientation_axis";
      if (usable(axis_key) && marks_.count(axis_key) && body.orientation_axis.norm() == 0.0)
        issue(axis_key, markOf(axis_key), "'" + axis_key + "' must be nonzero");
      const std::string mesh_key = indexed("soft_bodies", b) + ".mesh";
      if (!given(mesh_key) || body.mesh.empty()) continue;
      body.mesh_loc = locAt(mesh_key, markOf(mesh_key));
      loadClosedMesh(body.mesh, mesh_key, "soft body '" + body.name + "'", "soft bodies", body.mesh_data);
    }
  }

  // A mesh file named at `mesh_key`: found (relative to the scene file's folder, or to the working
  // directory when given with --set), not too big, and read; `file` becomes the absolute path.
  // False, with the issue reported at the key, when any of that fails.
  bool readMeshFile(std::string& file, const std::string& mesh_key, const std::string& label, TriMesh& mesh) {
    const YAML::Mark mark = markOf(mesh_key);
    fs::path path(file);
    if (path.is_relative()) {
      std::error_code ec;
      const bool from_command_line = !overrideFor(mesh_key).empty();
      const fs::path base = from_command_line || anchor_.empty() ? fs::current_path(ec) : anchor_.parent_path();
      path = base / path;
    }
    path = path.lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) {
      issue(mesh_key, mark, label + ": mesh file '" + file + "' not found (looked for " + path.string() + ")");
      return false;
    }
    if (const auto size = fs::file_size(path, ec); !ec && size > kMaxMeshBytes) {
      issue(mesh_key, mark, label + ": mesh file '" + file + "' has " + std::to_string(size) +
                                " bytes, more than the " + std::to_string(kMaxMeshBytes) + " a mesh may have");
      return false;
    }
    file = path.string();
    try {
      mesh = readObj(path.string());
    } catch (const InputError& e) {
      std::string why;
      for (const InputIssue& i : e.issues()) why += (why.empty() ? "" : "; ") + i.str();
      issue(mesh_key, mark, label + ": " + why);
      return false;
    }
    return true;
  }

  // A cloth's OBJ: found (relative to the scene file), readable, with triangles, and every edge in
  // at most two triangles (a surface, open or closed).
  void loadClothMesh(ClothSpec& cloth, const std::string& mesh_key, const std::string& label) {
    const YAML::Mark mark = markOf(mesh_key);
    TriMesh mesh;
    if (!readMeshFile(cloth.mesh, mesh_key, label, mesh)) return;
    const fs::path path(cloth.mesh);  // absolute now
    if (mesh.triangles.empty() || mesh.positions.empty()) {
      issue(mesh_key, mark, label + ": mesh " + path.string() + " has no triangles");
      return;
    }
    // Faces that do not share indices: weld within a millionth of the size.
    Eigen::Vector3f lo = mesh.positions[0], hi = mesh.positions[0];
    for (const auto& p : mesh.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    weldVertices(mesh, 1e-6f * (hi - lo).norm());
    if (mesh.triangles.empty()) {
      issue(mesh_key, mark, label + ": mesh " + path.string() + " has no triangles (all degenerate)");
      return;
    }
    const EdgeReport edges = checkEdges(mesh);
    if (edges.nonmanifold) {
      issue(mesh_key, mark, label + ": mesh " + path.string() + " has " + std::to_string(edges.nonmanifold) +
                                " non-manifold edge(s) (in 3 or more triangles): a cloth is a surface");
      return;
    }
    mesh.normals.clear();
    mesh.colours.clear();
    cloth.mesh_data = std::move(mesh);
  }

  // Keyframed cloth anchors: keyframes replace velocity / stop (not both), need at least one key,
  // and their times strictly increase.
  void checkAnchorKeyframes(const SceneSpec& spec) {
    // Cloths' anchors, then soft bodies' (the same rules).
    std::vector<std::pair<std::string, const std::vector<ClothAnchorSpec>*>> owners;
    for (std::size_t c = 0; c < spec.cloth.size(); ++c) owners.emplace_back(indexed("cloth", c), &spec.cloth[c].anchors);
    for (std::size_t b = 0; b < spec.soft_bodies.size(); ++b)
      owners.emplace_back(indexed("soft_bodies", b), &spec.soft_bodies[b].anchors);
    for (const auto& [owner, anchors] : owners)
      for (std::size_t a = 0; a < anchors->size(); ++a) {
        const std::string item = indexed(owner + ".anchors", a), list = item + ".keyframes";
        if (!marks_.count(list) || !usable(list)) continue;
        const auto& keys = (*anchors)[a].keyframes;
        for (const char* k : {".velocity", ".stop"})
          if (marks_.count(item + k))
            issue(item + k, markOf(item + k),
                  "'" + item + k + "' and '" + list + "' both given: an anchor moves either at a constant velocity or "
                  "along keyframes, not both");
        if (keys.empty()) issue(list, markOf(list), "'" + list + "' needs at least 1 key");
        for (std::size_t k = 1; k < keys.size(); ++k) {
          const std::string key = indexed(list, k);
          if (given(key + ".time") && given(indexed(list, k - 1) + ".time") && !(keys[k].time > keys[k - 1].time))
            issue(key + ".time", markOf(key + ".time"),
                  "'" + key + ".time' = " + numberText(keys[k].time) + " must be greater than the previous key's time " +
                      numberText(keys[k - 1].time) + " (keyframe times strictly increase)");
        }
      }
  }

  // Probes and gauges: names unique across both lists, and made of letters, digits, '_' and '-'
  // (they become probes.csv column names).
  void checkProbes(const SceneSpec& spec) {
    std::vector<std::pair<std::string, std::string>> seen;  // name, its item path
    auto check = [&](const std::string& item, const std::string& name) {
      if (!usable(item) || !given(item + ".name")) return;
      const std::string at = item + ".name";
      const bool safe = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
      });
      if (!safe)
        issue(at, markOf(at), "'" + at + "' = '" + name + "': use letters, digits, '_' and '-' (it names CSV columns)");
      for (const auto& [other, where] : seen)
        if (other == name) issue(at, markOf(at), "duplicate probe name '" + name + "' (already the name of " + where + ")");
      seen.emplace_back(name, item);
    };
    for (std::size_t i = 0; i < spec.probes.points.size(); ++i)
      check(indexed("probes.points", i), spec.probes.points[i].name);
    for (std::size_t i = 0; i < spec.probes.gauges.size(); ++i)
      check(indexed("probes.gauges", i), spec.probes.gauges[i].name);
  }

  // Rigid bodies: unique names, exactly one of density and mass, a nonzero orientation axis, no
  // script on a dynamic body, and for shape mesh a readable, closed, outward-facing OBJ file
  // (read here, so that a bad mesh is reported at its key like any other bad value).
  void checkBodies(SceneSpec& spec) {
    std::vector<std::string> names;
    for (std::size_t i = 0; i < spec.rigid_bodies.size(); ++i) {
      RigidBodySpec& body = spec.rigid_bodies[i];
      const std::string item = indexed("rigid_bodies", i);
      if (!usable(item)) continue;
      const std::string label = "rigid body '" + body.name + "'";
      if (given(item + ".name")) {
        if (body.name.empty()) {
          issue(item + ".name", markOf(item + ".name"), "'" + item + ".name' must not be empty");
        } else if (auto j = std::find(names.begin(), names.end(), body.name); j != names.end()) {
          issue(item + ".name", markOf(item + ".name"),
                "duplicate rigid body name '" + body.name + "' (already the name of " +
                    indexed("rigid_bodies", static_cast<std::size_t>(j - names.begin())) + ")");
        }
      }
      names.push_back(body.name);
      // The name becomes part of file names (body_<name>_0001.obj): letters, digits, '_', '-' and
      // '.', not starting with '.', so that no name can reach outside the output folder.
      if (given(item + ".name") && !body.name.empty() && !safeFileName(body.name))
        issue(item + ".name", markOf(item + ".name"),
              "rigid body name '" + body.name + "' is used in file names: use letters, digits, '_', '-' and '.' only "
              "(at most 64, not starting with '.')");
      // A dynamic body must start inside the domain: outside it, it falls forever and meets nothing.
      if (body.dynamic && given(item + ".position") &&
          !((body.position.array() >= spec.domain.min.array()).all() && (body.position.array() <= spec.domain.max.array()).all()))
        issue(item + ".position", markOf(item + ".position"),
              label + " is dynamic but starts outside the domain (" + vecText(body.position) + " is not within " +
                  vecText(spec.domain.min) + " .. " + vecText(spec.domain.max) + ")");

      const bool has_density = marks_.count(item + ".density") > 0, has_mass = marks_.count(item + ".mass") > 0;
      if (has_density && has_mass)
        issue(item + ".mass", markOf(item + ".mass"),
              label + ": give either 'density' or 'mass', not both");
      else if (!has_density && !has_mass)
        issue(item, markOf(item), label + ": give its 'density' (kg/m^3) or its 'mass' (kg)");

      if (usable(item + ".orientation_axis") && body.orientation_axis.norm() == 0.0)
        issue(item + ".orientation_axis", markOf(item + ".orientation_axis"),
              "'" + item + ".orientation_axis' must be nonzero");
      if (body.dynamic && body.motion.type != MotionType::None && marks_.count(item + ".motion.type"))
        issue(item + ".motion.type", markOf(item + ".motion.type"),
              label + " is dynamic, so it cannot follow a scripted motion (set 'dynamic: false' for a kinematic body)");
      checkKeyframes(body, item, label);
      // The position is required, except for a keyframed body: its keys give the pose.
      if (!marks_.count(item + ".position")) {
        if (body.motion.type == MotionType::Keyframes && !body.motion.keyframes.empty())
          body.position = body.motion.keyframes.front().position;
        else if (const KeyDef* def = findKey("rigid_bodies[].position"))
          issue(item + ".position", markOf(item),
                "missing required key '" + item + ".position' (" + expectation(*def) + ")");
      }

      const std::string mesh_key = item + ".mesh";
      if (body.shape != BodyShape::Mesh) {
        if (marks_.count(mesh_key))
          issue(mesh_key, markOf(mesh_key), label + ": 'mesh' is only used with 'shape: mesh' (shape is " +
                                                std::string(enumName(body.shape)) + ")");
        continue;
      }
      if (!marks_.count(mesh_key)) {
        if (usable(item + ".shape")) issue(item, markOf(item), label + ": 'shape: mesh' needs a 'mesh' file (OBJ)");
        continue;
      }
      if (!usable(mesh_key)) continue;
      body.mesh_loc = locAt(mesh_key, markOf(mesh_key));
      loadBodyMesh(body, mesh_key, label);
    }
  }

  void checkHaptics(SceneSpec& spec) {
    HapticsSpec& h = spec.haptics;
    h.enabled = true;
    h.offset_given = marks_.count("haptics.offset") > 0;
    if (!h.offset_given) h.offset = 0.5 * (spec.domain.min + spec.domain.max);
    if (usable("haptics.rotation_axis") && h.rotation_axis.norm() == 0.0)
      issue("haptics.rotation_axis", markOf("haptics.rotation_axis"), "'haptics.rotation_axis' must be nonzero");
    if (usable("haptics.continuous_force") && usable("haptics.peak_force") && h.continuous_force > h.peak_force)
      issue("haptics.continuous_force", markOf("haptics.continuous_force"),
            "'haptics.continuous_force' = " + numberText(h.continuous_force) + " N must not exceed 'haptics.peak_force' = " +
                numberText(h.peak_force) + " N");
    for (std::size_t k = 0; k < h.path.size(); ++k) {
      const std::string key = indexed("haptics.path", k);
      if (!usable(key)) continue;
      const PathSegmentSpec& p = h.path[k];
      if (usable(key + ".end") && usable(key + ".start") && !(p.end > p.start))
        issue(key + ".end", markOf(marks_.count(key + ".end") ? key + ".end" : key),
              "'" + key + ".end' = " + numberText(p.end) + " s must be greater than its start " + numberText(p.start) + " s");
      if (p.type == PathSegmentType::Circle && usable(key + ".axis") && p.axis.norm() == 0.0)
        issue(key + ".axis", markOf(key + ".axis"), "'" + key + ".axis' must be nonzero");
    }
    for (std::size_t k = 1; k < h.waypoints.size(); ++k) {
      const std::string key = indexed("haptics.waypoints", k);
      if (given(key + ".time") && given(indexed("haptics.waypoints", k - 1) + ".time") &&
          !(h.waypoints[k].time > h.waypoints[k - 1].time))
        issue(key + ".time", markOf(key + ".time"),
              "'" + key + ".time' = " + numberText(h.waypoints[k].time) + " must be greater than the previous waypoint's time " +
                  numberText(h.waypoints[k - 1].time));
    }
  }

  // Keyframes: only with motion.type keyframes, which needs at least 2 of them, with strictly
  // increasing times and nonzero axes; a key without orientation takes the body's.
  void checkKeyframes(RigidBodySpec& body, const std::string& item, const std::string& label) {
    const std::string list = item + ".motion.keyframes", type_key = item + ".motion.type";
    auto& keys = body.motion.keyframes;
    if (body.motion.type != MotionType::Keyframes) {
      if (marks_.count(list) && usable(type_key))
        issue(list, markOf(list), label + ": 'motion.keyframes' is only used with 'motion.type: keyframes' (type is " +
                                      std::string(enumName(body.motion.type)) + ")");
      return;
    }
    if (!usable(list)) return;
    if (keys.size() < 2) {
      const std::string at = marks_.count(list) ? list : type_key;
      issue(at, markOf(at), label + ": 'motion.type: keyframes' needs a list 'motion.keyframes' of at least 2 keys, got " +
                                std::to_string(keys.size()));
      return;
    }
    for (std::size_t k = 0; k < keys.size(); ++k) {
      const std::string key = indexed(list, k);
      if (!usable(key)) continue;
      if (!marks_.count(key + ".orientation_axis") && !marks_.count(key + ".orientation_angle")) {
        keys[k].orientation_axis = body.orientation_axis;
        keys[k].orientation_angle = body.orientation_angle;
      }
      if (usable(key + ".orientation_axis") && keys[k].orientation_axis.norm() == 0.0)
        issue(key + ".orientation_axis", markOf(key + ".orientation_axis"), "'" + key + ".orientation_axis' must be nonzero");
      if (k > 0 && given(key + ".time") && given(indexed(list, k - 1) + ".time") && !(keys[k].time > keys[k - 1].time))
        issue(key + ".time", markOf(key + ".time"),
              "'" + key + ".time' = " + numberText(keys[k].time) + " must be greater than the previous key's time " +
                  numberText(keys[k - 1].time) + " (keyframe times strictly increase)");
    }
  }

  void loadBodyMesh(RigidBodySpec& body, const std::string& mesh_key, const std::string& label) {
    loadClosedMesh(body.mesh, mesh_key, label, "rigid bodies", body.mesh_data);
  }

  // A closed mesh (a rigid body's, a soft body's): found, read, welded, watertight with consistent
  // winding and a positive volume, else an issue at `mesh_key` saying what `who` need.
  void loadClosedMesh(std::string& file, const std::string& mesh_key, const std::string& label, const std::string& who,
                      TriMesh& out) {
    const YAML::Mark mark = markOf(mesh_key);
    TriMesh mesh;
    if (!readMeshFile(file, mesh_key, label, mesh)) return;
    const fs::path path(file);  // absolute now
    // OBJ exporters often repeat a vertex for each face: weld within a millionth of the size.
    Eigen::Vector3f lo = mesh.positions[0], hi = mesh.positions[0];
    for (const auto& p : mesh.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    weldVertices(mesh, 1e-6f * (hi - lo).norm());
    const EdgeReport edges = checkEdges(mesh);
    if (!edges.closed()) {
      std::string what;
      if (edges.boundary) what += std::to_string(edges.boundary) + " open (boundary) edge(s)";
      if (edges.nonmanifold) what += (what.empty() ? "" : ", ") + std::to_string(edges.nonmanifold) + " non-manifold edge(s)";
      if (edges.misoriented)
        what += (what.empty() ? "" : ", ") + std::to_string(edges.misoriented) + " edge(s) with inconsistent winding";
      issue(mesh_key, mark, label + ": mesh " + path.string() + " is not closed: " + what + " (" + who + " need a watertight mesh)");
      return;
    }
    if (meshVolume(mesh) <= 0.0) {
      issue(mesh_key, mark, label + ": mesh " + path.string() +
                                " encloses a negative volume: its triangles face inward (reverse their winding)");
      return;
    }
    mesh.normals.clear();  // the body frame's geometry is all that is kept
    mesh.colours.clear();
    out = std::move(mesh);
  }

  std::string file_;                                 // as shown in messages
  fs::path anchor_;                                  // the scene file (absolute), or empty
  std::vector<InputIssue> issues_;
  std::map<std::string, YAML::Mark> marks_;          // concrete path -> where its value is
  std::set<std::string> bad_;                        // concrete paths whose value was rejected
  std::map<std::string, std::string> overridden_;    // concrete path -> the --set text that wrote it
};

/// Loads from text; `file` names it in messages, `anchor` (absolute, may be empty) is the scene
/// file that relative paths inside it are relative to.
SceneSpec loadText(const std::string& text, const std::string& file, const fs::path& anchor,
                   const std::vector<std::string>& overrides) {
  Loader loader(file, anchor);
  SceneSpec spec = loader.load(text, overrides);
  spec.source_file = anchor.string();

  // output.directory: relative to the scene file's folder when written in the scene; relative
  // to the working directory when given with --set (as any command-line path).
  if (!spec.output.directory.empty()) {
    fs::path dir(spec.output.directory);
    if (dir.is_relative()) {
      std::error_code ec;
      const bool from_command_line = !loader.overrideFor("output.directory").empty();
      const fs::path base = from_command_line || anchor.empty() ? fs::current_path(ec) : anchor.parent_path();
      dir = base / dir;
    }
    spec.output.directory = dir.lexically_normal().string();
  }
  return spec;
}

fs::path absolutePath(const std::string& path) {
  if (path.empty()) return {};
  std::error_code ec;
  fs::path abs = fs::absolute(path, ec);
  return ec ? fs::path(path) : abs.lexically_normal();
}

// ---------------------------------------------------------------------------------------------
// JSON output (written by hand; no JSON library is a dependency)
// ---------------------------------------------------------------------------------------------

std::string jsonQuote(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += ch;  // UTF-8 bytes pass through
        }
    }
  }
  return out + "\"";
}

/// Numbers in JSON: shortest round-trip decimal; infinities as the strings "inf" / "-inf" (JSON
/// has no infinity), NaN as null.
std::string jsonNumber(double v) {
  if (std::isnan(v)) return "null";
  if (std::isinf(v)) return v > 0 ? "\"inf\"" : "\"-inf\"";
  return numberText(v);
}

std::string jsonValue(const Value& value) {
  struct Visitor {
    std::string operator()(double v) const { return jsonNumber(v); }
    std::string operator()(long v) const { return std::to_string(v); }
    std::string operator()(bool v) const { return v ? "true" : "false"; }
    std::string operator()(const std::string& v) const { return jsonQuote(v); }
    std::string operator()(const Eigen::Vector3d& v) const {
      return "[" + jsonNumber(v.x()) + ", " + jsonNumber(v.y()) + ", " + jsonNumber(v.z()) + "]";
    }
  };
  return std::visit(Visitor{}, value);
}

/// Writes the members of one object (section or list item) in schema order.
void jsonMembers(std::string& out, const SceneSpec& spec, const std::string& schema_prefix, std::size_t index,
                 int indent, bool first) {
  const std::string pad(static_cast<std::size_t>(indent), ' ');
  for (const KeyDef* key : childKeys(schema_prefix)) {
    out += first ? "\n" : ",\n";
    first = false;
    out += pad + jsonQuote(key->name()) + ": ";
    if (key->type == KeyType::Map) {
      out += "{";
      jsonMembers(out, spec, key->path, index, indent + 2, true);
      out += "\n" + pad + "}";
    } else if (key->type == KeyType::List) {
      const std::size_t n = key->count(spec, index);
      if (n == 0) {
        out += "[]";
        continue;
      }
      out += "[";
      for (std::size_t i = 0; i < n; ++i) {
        out += (i ? ",\n" : "\n") + pad + "  {";
        jsonMembers(out, spec, key->path + "[]", key->item_index(index, i), indent + 4, true);
        out += "\n" + pad + "  }";
      }
      out += "\n" + pad + "]";
    } else {
      out += jsonValue(key->get(spec, index));
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Public entry points
// ---------------------------------------------------------------------------------------------

SceneSpec loadScene(const std::string& path, const std::vector<std::string>& overrides) {
  // A missing or unreadable file is reported against its path, with no line.
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, 0, 0, "cannot open the scene file: no such file");
  if (fs::is_directory(path, ec)) throw InputError(path, 0, 0, "cannot read the scene file: it is a directory");
  // Only a regular file of sane size is read (not /dev/zero, a FIFO or a 10 GB file).
  if (!fs::is_regular_file(path, ec))
    throw InputError(path, 0, 0, "cannot read the scene file: not a regular file (a device, FIFO or socket)");
  if (const auto size = fs::file_size(path, ec); !ec && size > kMaxSceneBytes)
    throw InputError(path, 0, 0, "cannot read the scene file: " + std::to_string(size) + " bytes, more than the " +
                                     std::to_string(kMaxSceneBytes) + " a scene may have");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(path, 0, 0, std::string("cannot open the scene file: ") + (errno ? std::strerror(errno) : "unreadable"));
  std::ostringstream text;
  text << in.rdbuf();
  return loadText(text.str(), path, absolutePath(path), overrides);
}

SceneSpec loadSceneFromString(const std::string& yaml, const std::string& virtual_path,
                              const std::vector<std::string>& overrides) {
  return loadText(yaml, virtual_path.empty() ? "<string>" : virtual_path, absolutePath(virtual_path), overrides);
}

std::string sceneToJson(const SceneSpec& spec) {
  std::string out = "{\n  \"source_file\": " + jsonQuote(spec.source_file);
  jsonMembers(out, spec, "", 0, 2, false);
  return out + "\n}\n";
}

}  // namespace sph::io

// The schema table behind io/schema.h: one KeyDef per scene key, in the order they are printed.
//
// Each entry names a key by its schema path ("simulation.duration", "domain.closed.x_min",
// "fluid.phases[].rest_density"; "[]" stands for "every item of the list"), says its type, unit,
// allowed values and doc, and binds it to its SceneSpec field through get/set functions. The
// defaults are never written here: they are read from a default-constructed SceneSpec (and
// PhaseSpec, BlockSpec, InflowSpec, RigidBodySpec), so core/scene_spec.h stays the one place that defines them.
//
// Users of the table: the scene loader (which keys exist, their types and ranges, where to store
// them), schemaText() (`sphaptics schema`) and sceneToJson() (run.json).
#pragma once

#include "core/scene_spec.h"

#include <Eigen/Core>

#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace sph::io {

/// Name of the phase created when a scene defines no `fluid.phases`.
inline constexpr const char* kDefaultPhaseName = "water";

// ---------------------------------------------------------------------------------------------
// Enum values as they are spelled in YAML (DESIGN.md section 6: enum values are strings).
// ---------------------------------------------------------------------------------------------

template <class E>
struct EnumNames;  // specialised below: `values`, an array of {enumerator, YAML spelling}

template <>
struct EnumNames<KernelType> {
  static constexpr std::pair<KernelType, const char*> values[] = {
      {KernelType::CubicSpline, "cubic_spline"}, {KernelType::WendlandC2, "wendland_c2"}};
};
template <>
struct EnumNames<EquationOfState> {
  static constexpr std::pair<EquationOfState, const char*> values[] = {{EquationOfState::Linear, "linear"},
                                                                         {EquationOfState::Tait, "tait"}};
};
template <>
struct EnumNames<ViscosityModel> {
  static constexpr std::pair<ViscosityModel, const char*> values[] = {{ViscosityModel::Artificial, "artificial"},
                                                                        {ViscosityModel::Laminar, "laminar"}};
};
template <>
struct EnumNames<BodyViscosity> {
  static constexpr std::pair<BodyViscosity, const char*> values[] = {{BodyViscosity::Fluid, "fluid"},
                                                                       {BodyViscosity::Physical, "physical"}};
};
template <>
struct EnumNames<BodyAmbientPressure> {
  static constexpr std::pair<BodyAmbientPressure, const char*> values[] = {{BodyAmbientPressure::Auto, "auto"},
                                                                             {BodyAmbientPressure::Subtract, "subtract"},
                                                                             {BodyAmbientPressure::Keep, "keep"}};
};
template <>
struct EnumNames<BoundaryVelocity> {
  static constexpr std::pair<BoundaryVelocity, const char*> values[] = {
      {BoundaryVelocity::Auto, "auto"}, {BoundaryVelocity::Ghost, "ghost"}, {BoundaryVelocity::Wall, "wall"}};
};
template <>
struct EnumNames<FluidSolver> {
  static constexpr std::pair<FluidSolver, const char*> values[] = {{FluidSolver::Wcsph, "wcsph"},
                                                                     {FluidSolver::Dfsph, "dfsph"}};
};
template <>
struct EnumNames<DfsphWalls> {
  static constexpr std::pair<DfsphWalls, const char*> values[] = {{DfsphWalls::Mirrored, "mirrored"},
                                                                    {DfsphWalls::Single, "single"},
                                                                    {DfsphWalls::Extrapolated, "extrapolated"}};
};
template <>
struct EnumNames<DfsphCoupling> {
  static constexpr std::pair<DfsphCoupling, const char*> values[] = {{DfsphCoupling::Strong, "strong"},
                                                                            {DfsphCoupling::Staggered, "staggered"}};
};
template <>
struct EnumNames<ViscositySolve> {
  static constexpr std::pair<ViscositySolve, const char*> values[] = {{ViscositySolve::Auto, "auto"},
                                                                        {ViscositySolve::Explicit, "explicit"},
                                                                        {ViscositySolve::Implicit, "implicit"}};
};
template <>
struct EnumNames<TimeStepControl> {
  static constexpr std::pair<TimeStepControl, const char*> values[] = {{TimeStepControl::Subdivide, "subdivide"},
                                                                         {TimeStepControl::Warn, "warn"}};
};
template <>
struct EnumNames<NumericalPolicy> {
  static constexpr std::pair<NumericalPolicy, const char*> values[] = {{NumericalPolicy::Warn, "warn"},
                                                                         {NumericalPolicy::Abort, "abort"}};
};
template <>
struct EnumNames<NozzleShape> {
  static constexpr std::pair<NozzleShape, const char*> values[] = {{NozzleShape::Circle, "circle"},
                                                                     {NozzleShape::Rectangle, "rectangle"}};
};

template <>
struct EnumNames<BodyShape> {
  static constexpr std::pair<BodyShape, const char*> values[] = {{BodyShape::Mesh, "mesh"},
                                                                   {BodyShape::Sphere, "sphere"},
                                                                   {BodyShape::Box, "box"},
                                                                   {BodyShape::Cylinder, "cylinder"},
                                                                   {BodyShape::Capsule, "capsule"}};
};
template <>
struct EnumNames<MotionType> {
  static constexpr std::pair<MotionType, const char*> values[] = {{MotionType::None, "none"},
                                                                    {MotionType::Constant, "constant"},
                                                                    {MotionType::Keyframes, "keyframes"}};
};

template <>
struct EnumNames<HapticBackend> {
  static constexpr std::pair<HapticBackend, const char*> values[] = {{HapticBackend::Scripted, "scripted"},
                                                                       {HapticBackend::Simulated, "simulated"},
                                                                       {HapticBackend::Bridge, "bridge"}};
};
template <>
struct EnumNames<HapticSmoothing> {
  static constexpr std::pair<HapticSmoothing, const char*> values[] = {{HapticSmoothing::Servo, "servo"},
                                                                         {HapticSmoothing::RollingAverage, "rolling_average"}};
};
template <>
struct EnumNames<PathSegmentType> {
  static constexpr std::pair<PathSegmentType, const char*> values[] = {{PathSegmentType::Line, "line"},
                                                                         {PathSegmentType::Circle, "circle"},
                                                                         {PathSegmentType::Sine, "sine"}};
};
template <>
struct EnumNames<ClothSolver> {
  static constexpr std::pair<ClothSolver, const char*> values[] = {{ClothSolver::Xpbd, "xpbd"},
                                                                     {ClothSolver::Explicit, "explicit"}};
};
template <>
struct EnumNames<AnchorType> {
  static constexpr std::pair<AnchorType, const char*> values[] = {{AnchorType::Corners, "corners"},
                                                                    {AnchorType::Edge, "edge"},
                                                                    {AnchorType::Node, "node"},
                                                                    {AnchorType::Box, "box"}};
};
template <>
struct EnumNames<ClothEdge> {
  static constexpr std::pair<ClothEdge, const char*> values[] = {{ClothEdge::XMin, "x_min"},
                                                                   {ClothEdge::XMax, "x_max"},
                                                                   {ClothEdge::YMin, "y_min"},
                                                                   {ClothEdge::YMax, "y_max"},
                                                                   {ClothEdge::ZMin, "z_min"},
                                                                   {ClothEdge::ZMax, "z_max"}};
};

/// The YAML spelling of an enum value, e.g. enumName(KernelType::WendlandC2) == "wendland_c2".
template <class E>
const char* enumName(E e) {
  for (const auto& [value, name] : EnumNames<E>::values)
    if (value == e) return name;
  return "?";
}

/// Parses a YAML spelling; returns false (leaving `out` alone) when `name` is not one of them.
template <class E>
bool enumFromName(const std::string& name, E& out) {
  for (const auto& [value, spelling] : EnumNames<E>::values)
    if (name == spelling) {
      out = value;
      return true;
    }
  return false;
}

template <class E>
std::vector<std::string> enumSpellings() {
  std::vector<std::string> names;
  for (const auto& entry : EnumNames<E>::values) names.emplace_back(entry.second);
  return names;
}

// ---------------------------------------------------------------------------------------------
// Key definitions
// ---------------------------------------------------------------------------------------------

enum class KeyType { Float, Int, Bool, String, Enum, Vec3, Map, List };

/// "float", "int", "bool", "string", "enum", "vec3", "map", "list".
const char* keyTypeName(KeyType type);

/// A key's value, independent of the field it is stored in. Int fields travel as long, enum
/// fields as their YAML spelling.
using Value = std::variant<double, long, bool, std::string, Eigen::Vector3d>;

/// Allowed numeric interval, applied to float and int keys and to each component of vec3 keys.
struct NumRange {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;  ///< true: value > lo; false: value >= lo
  bool hi_open = false;  ///< true: value < hi; false: value <= hi
  bool contains(double v) const;
  bool unbounded() const;
  std::string str() const;  ///< "> 0", ">= 1", "[1.5, 4]", "(0, 1]", "" when unbounded
};

struct KeyDef {
  std::string path;            ///< schema path, e.g. "fluid.phases[].rest_density"
  KeyType type = KeyType::Float;
  std::string unit;            ///< SI unit ("s", "m", "kg/m^3", "1" for dimensionless); "" when not a quantity
  std::string doc;             ///< one line
  bool required = false;       ///< must be present whenever its parent section or list item is
  bool allow_infinity = false; ///< floats only: accept .inf (otherwise every float must be finite)
  NumRange range;              ///< float, int, vec3 components
  double int_max = std::numeric_limits<double>::infinity();  ///< ints: the largest value the C++ field holds
  std::vector<std::string> choices;  ///< enum spellings
  std::string default_note;    ///< shown instead of the default value when set (lists, implied defaults)

  /// Leaf keys: read / write the field; `index` selects the list item (ignored outside lists).
  std::function<Value(const SceneSpec&, std::size_t index)> get;
  std::function<void(SceneSpec&, std::size_t index, const Value&)> set;
  /// Sections (the section's loc) and lists (item `index`'s loc); null when there is none.
  std::function<SourceLoc*(SceneSpec&, std::size_t index)> loc;
  /// Lists only: number of items, and resize to n default-constructed items. `parent` is the
  /// index of the item the list belongs to (a list inside a list item, such as
  /// rigid_bodies[].motion.keyframes); top-level lists ignore it.
  std::function<std::size_t(const SceneSpec&, std::size_t parent)> count;
  std::function<void(SceneSpec&, std::size_t parent, std::size_t n)> resize;
  /// Lists only: the index that the keys of item i take (see nestedIndex); i for top-level lists.
  std::function<std::size_t(std::size_t parent, std::size_t i)> item_index;

  bool isLeaf() const { return type != KeyType::Map && type != KeyType::List; }
  std::string parent() const;  ///< "fluid.phases[]" for "fluid.phases[].name"; "" for top-level sections
  std::string name() const;    ///< last segment: "name"
};

/// The index passed to the keys of item `i` of a list inside item `parent` of a top-level list:
/// the parent in the low 32 bits, the item in the high ones (nestedParent / nestedItem undo it).
inline std::size_t nestedIndex(std::size_t parent, std::size_t i) { return (parent & 0xffffffffu) | (i << 32); }
inline std::size_t nestedParent(std::size_t index) { return index & 0xffffffffu; }
inline std::size_t nestedItem(std::size_t index) { return index >> 32; }
/// The index passed to the keys of item `i` of a list inside an item of a nested list
/// (cloth[].anchors[].keyframes[]): `parent` is that item's nestedIndex; the top-level item in
/// bits 0-15, the nested item in bits 16-31, i in the high 32 (so up to 65536 of each outer level).
inline std::size_t nested2Index(std::size_t parent, std::size_t i) {
  return (nestedParent(parent) & 0xffffu) | ((nestedItem(parent) & 0xffffu) << 16) | (i << 32);
}
inline std::size_t nested2Top(std::size_t index) { return index & 0xffffu; }
inline std::size_t nested2Middle(std::size_t index) { return (index >> 16) & 0xffffu; }

/// Every key, parents before their children, in the order of the YAML sections.
const std::vector<KeyDef>& schemaTable();

/// The entry with this schema path, or nullptr.
const KeyDef* findKey(const std::string& schema_path);

/// The direct children of a section ("" for the top level; "fluid.phases[]" for phase items).
std::vector<const KeyDef*> childKeys(const std::string& parent_path);

/// The default value of a key as text (from the default-constructed specs), or its default_note.
std::string defaultText(const KeyDef& key);

/// A value as text in YAML flow style: 0.4, 4, true, cubic_spline, [0, 0, -9.81].
std::string valueText(const Value& value);

/// Shortest decimal text that reads back as the same double ("0.4", "1e-06", "inf").
std::string numberText(double v);

}  // namespace sph::io

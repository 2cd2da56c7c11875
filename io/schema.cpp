// The schema table: every scene key, once. See io/schema_table.h for what an entry holds.
//
// Reading guide: buildTable() at the bottom lists the keys section by section. Each entry is
//   field<Scope>("path", [](auto& x) -> auto& { return x.member; }).unit(..).range(..).doc(..)
// where Scope says whether the field lives in the SceneSpec itself or in one item of a list
// (phases, blocks, inflows), and the lambda picks the member. The key's type (float, int, ...)
// and, for enums, its allowed spellings follow from the member's C++ type.
#include "io/schema.h"

#include "io/schema_table.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <type_traits>

namespace sph::io {

// ---------------------------------------------------------------------------------------------
// Small helpers on keys and values
// ---------------------------------------------------------------------------------------------

const char* keyTypeName(KeyType type) {
  switch (type) {
    case KeyType::Float: return "float";
    case KeyType::Int: return "int";
    case KeyType::Bool: return "bool";
    case KeyType::String: return "string";
    case KeyType::Enum: return "enum";
    case KeyType::Vec3: return "vec3";
    case KeyType::Map: return "map";
    case KeyType::List: return "list";
  }
  return "?";
}

bool NumRange::contains(double v) const {
  const bool above = lo_open ? v > lo : v >= lo;
  const bool below = hi_open ? v < hi : v <= hi;
  return above && below;
}

bool NumRange::unbounded() const { return std::isinf(lo) && std::isinf(hi); }

std::string NumRange::str() const {
  const bool has_lo = !std::isinf(lo), has_hi = !std::isinf(hi);
  if (has_lo && has_hi)
    return std::string(lo_open ? "(" : "[") + numberText(lo) + ", " + numberText(hi) + (hi_open ? ")" : "]");
  if (has_lo) return std::string(lo_open ? "> " : ">= ") + numberText(lo);
  if (has_hi) return std::string(hi_open ? "< " : "<= ") + numberText(hi);
  return "";
}

std::string KeyDef::parent() const {
  const auto dot = path.rfind('.');
  return dot == std::string::npos ? std::string() : path.substr(0, dot);
}

std::string KeyDef::name() const {
  const auto dot = path.rfind('.');
  return dot == std::string::npos ? path : path.substr(dot + 1);
}

std::string numberText(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  // Shortest %g precision that reads back to the same double ...
  int precision = 1;
  char buf[64];
  for (; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  // ... but plain digits rather than an exponent for moderate magnitudes (60, not 6e+01).
  const int exponent = v == 0.0 ? 0 : static_cast<int>(std::floor(std::log10(std::fabs(v))));
  if (exponent >= precision && exponent < 17) std::snprintf(buf, sizeof buf, "%.*g", exponent + 1, v);
  return buf;
}

std::string valueText(const Value& value) {
  struct Visitor {
    std::string operator()(double v) const { return numberText(v); }
    std::string operator()(long v) const { return std::to_string(v); }
    std::string operator()(bool v) const { return v ? "true" : "false"; }
    std::string operator()(const std::string& v) const { return v; }
    std::string operator()(const Eigen::Vector3d& v) const {
      return "[" + numberText(v.x()) + ", " + numberText(v.y()) + ", " + numberText(v.z()) + "]";
    }
  };
  return std::visit(Visitor{}, value);
}

// ---------------------------------------------------------------------------------------------
// Binding a key to its field: C++ type -> key type, field <-> Value
// ---------------------------------------------------------------------------------------------

namespace {
// cloth[].max_time_step and soft_bodies[].max_time_step (core/scene_spec.h, core/model.cpp).
const char* const kXpbdMaxTimeStepDoc =
    "xpbd: a longer step is taken in equal substeps no longer than this (a fixed number of sweeps holds the springs "
    "less the longer the step; Macklin et al. 2019, small steps); .inf = one step; 0 = automatic: sqrt(0.05 L0 n m / "
    "W) for rest length L0, n sweeps, lightest free node m and heaviest dynamic ball's weight W (one step without balls), "
    "and at most 0.5 ms under the implicit viscosity (fluid.dfsph.viscosity_solve: implicit, or auto where it takes "
    "implicit) for cloth and soft bodies lighter than the liquid";

template <class T>
constexpr KeyType keyTypeOf() {
  if constexpr (std::is_same_v<T, bool>) return KeyType::Bool;
  else if constexpr (std::is_enum_v<T>) return KeyType::Enum;
  else if constexpr (std::is_integral_v<T>) return KeyType::Int;
  else if constexpr (std::is_floating_point_v<T>) return KeyType::Float;
  else if constexpr (std::is_same_v<T, std::string>) return KeyType::String;
  else {
    static_assert(std::is_same_v<T, Eigen::Vector3d>, "unsupported field type in the schema table");
    return KeyType::Vec3;
  }
}

template <class T>
Value toValue(const T& field) {
  if constexpr (std::is_same_v<T, bool>) return Value(field);
  else if constexpr (std::is_enum_v<T>) return Value(std::string(enumName(field)));
  else if constexpr (std::is_integral_v<T>) return Value(static_cast<long>(field));
  else if constexpr (std::is_floating_point_v<T>) return Value(static_cast<double>(field));
  else return Value(field);  // std::string, Eigen::Vector3d
}

template <class T>
void fromValue(const Value& value, T& field) {
  if constexpr (std::is_same_v<T, bool>) field = std::get<bool>(value);
  else if constexpr (std::is_enum_v<T>) enumFromName(std::get<std::string>(value), field);
  else if constexpr (std::is_integral_v<T>) field = static_cast<T>(std::get<long>(value));
  else if constexpr (std::is_floating_point_v<T>) field = static_cast<T>(std::get<double>(value));
  else field = std::get<T>(value);
}

// Where a field lives: in the SceneSpec itself, or in item `index` of one of the fluid lists.
// `S` is SceneSpec or const SceneSpec, so one accessor serves both get and set.
struct InScene {
  using Item = SceneSpec;
  template <class S>
  static S& item(S& s, std::size_t) { return s; }
};
struct InPhases {
  using Item = PhaseSpec;
  template <class S>
  static auto& list(S& s) { return s.fluid.phases; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.fluid.phases.at(i); }
};
struct InBlocks {
  using Item = BlockSpec;
  template <class S>
  static auto& list(S& s) { return s.fluid.blocks; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.fluid.blocks.at(i); }
};
struct InInflows {
  using Item = InflowSpec;
  template <class S>
  static auto& list(S& s) { return s.fluid.inflows; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.fluid.inflows.at(i); }
};

struct InBodies {
  using Item = RigidBodySpec;
  template <class S>
  static auto& list(S& s) { return s.rigid_bodies; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.rigid_bodies.at(i); }
};

/// Keyframes of a body's motion: a list inside the rigid_bodies list (index: nestedIndex).
struct InPath {
  using Item = PathSegmentSpec;
  template <class S>
  static auto& list(S& s) { return s.haptics.path; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.haptics.path.at(i); }
};
struct InWaypoints {
  using Item = WaypointSpec;
  template <class S>
  static auto& list(S& s) { return s.haptics.waypoints; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.haptics.waypoints.at(i); }
};
struct InButtons {
  using Item = ButtonEventSpec;
  template <class S>
  static auto& list(S& s) { return s.haptics.buttons; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.haptics.buttons.at(i); }
};
struct InKeyframes {
  using Item = KeyframeSpec;
  template <class S>
  static auto& list(S& s, std::size_t parent) { return s.rigid_bodies.at(nestedParent(parent)).motion.keyframes; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return list(s, i).at(nestedItem(i)); }
};

struct InCloths {
  using Item = ClothSpec;
  template <class S>
  static auto& list(S& s) { return s.cloth; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.cloth.at(i); }
};

/// Anchors of a cloth or a soft body (`Owners`: &SceneSpec::cloth or &SceneSpec::soft_bodies): a
/// list inside the owners' list (index: nestedIndex).
template <auto Owners>
struct InAnchorsOf {
  using Item = ClothAnchorSpec;
  template <class S>
  static auto& list(S& s, std::size_t parent) { return (s.*Owners).at(nestedParent(parent)).anchors; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return list(s, i).at(nestedItem(i)); }
};

/// Keyframes of such an anchor: a list inside an anchor (index: nested2Index).
template <auto Owners>
struct InAnchorKeysOf {
  using Item = AnchorKeyframeSpec;
  /// `parent`: the anchor's nestedIndex (count / resize).
  template <class S>
  static auto& list(S& s, std::size_t parent) {
    return (s.*Owners).at(nestedParent(parent)).anchors.at(nestedItem(parent)).keyframes;
  }
  /// `i`: nested2Index of the key.
  template <class S>
  static auto& item(S& s, std::size_t i) {
    return (s.*Owners).at(nested2Top(i)).anchors.at(nested2Middle(i)).keyframes.at(nestedItem(i));
  }
};

using InAnchors = InAnchorsOf<&SceneSpec::cloth>;
using InAnchorKeys = InAnchorKeysOf<&SceneSpec::cloth>;
using InSoftAnchors = InAnchorsOf<&SceneSpec::soft_bodies>;
using InSoftAnchorKeys = InAnchorKeysOf<&SceneSpec::soft_bodies>;

struct InSoftBodies {
  using Item = SoftBodySpec;
  template <class S>
  static auto& list(S& s) { return s.soft_bodies; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.soft_bodies.at(i); }
};

struct InProbePoints {
  using Item = PointProbeSpec;
  template <class S>
  static auto& list(S& s) { return s.probes.points; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.probes.points.at(i); }
};

struct InGauges {
  using Item = GaugeSpec;
  template <class S>
  static auto& list(S& s) { return s.probes.gauges; }
  template <class S>
  static auto& item(S& s, std::size_t i) { return s.probes.gauges.at(i); }
};

/// Fluent builder for one KeyDef (see buildTable()).
class Key {
 public:
  explicit Key(std::string path, KeyType type) {
    def.path = std::move(path);
    def.type = type;
  }
  Key& unit(const char* u) { def.unit = u; return *this; }
  Key& doc(const char* d) { def.doc = d; return *this; }
  Key& required() { def.required = true; return *this; }
  Key& allowInfinity() { def.allow_infinity = true; return *this; }
  Key& defaultNote(const char* note) { def.default_note = note; return *this; }
  Key& greaterThan(double lo) { def.range.lo = lo; def.range.lo_open = true; return *this; }
  Key& atLeast(double lo) { def.range.lo = lo; def.range.lo_open = false; return *this; }
  Key& atMost(double hi) { def.range.hi = hi; def.range.hi_open = false; return *this; }
  Key& lessThan(double hi) { def.range.hi = hi; def.range.hi_open = true; return *this; }
  KeyDef def;
};

/// A leaf key bound to the field `ref(item)` of its scope.
template <class Scope, class Ref>
Key field(const char* path, Ref ref) {
  using T = std::remove_cv_t<std::remove_reference_t<decltype(ref(std::declval<typename Scope::Item&>()))>>;
  Key key(path, keyTypeOf<T>());
  key.def.get = [ref](const SceneSpec& s, std::size_t i) { return toValue(ref(Scope::item(s, i))); };
  key.def.set = [ref](SceneSpec& s, std::size_t i, const Value& v) { fromValue(v, ref(Scope::item(s, i))); };
  if constexpr (std::is_enum_v<T>) key.def.choices = enumSpellings<T>();
  // Integers must also fit their C++ type.
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool> && !std::is_enum_v<T>)
    key.def.int_max = static_cast<double>(std::numeric_limits<T>::max());
  return key;
}

/// A section (YAML map) whose location goes to `loc(scene)`; pass nullptr when it has none.
Key section(const char* path, SourceLoc* (*loc)(SceneSpec&)) {
  Key key(path, KeyType::Map);
  if (loc) key.def.loc = [loc](SceneSpec& s, std::size_t) { return loc(s); };
  return key;
}

/// A list of objects; its items' keys are declared with the same Scope under "path[]".
template <class Scope>
Key list(const char* path) {
  Key key(path, KeyType::List);
  key.def.count = [](const SceneSpec& s, std::size_t) { return Scope::list(s).size(); };
  key.def.resize = [](SceneSpec& s, std::size_t, std::size_t n) { Scope::list(s).resize(n); };
  key.def.item_index = [](std::size_t, std::size_t i) { return i; };
  key.def.loc = [](SceneSpec& s, std::size_t i) { return &Scope::item(s, i).loc; };
  return key;
}

/// A list inside an item of a top-level list; its items' keys get nestedIndex(parent, i).
template <class Scope>
Key nestedList(const char* path) {
  Key key(path, KeyType::List);
  key.def.count = [](const SceneSpec& s, std::size_t parent) { return Scope::list(s, parent).size(); };
  key.def.resize = [](SceneSpec& s, std::size_t parent, std::size_t n) { Scope::list(s, parent).resize(n); };
  key.def.item_index = [](std::size_t parent, std::size_t i) { return nestedIndex(parent, i); };
  key.def.loc = [](SceneSpec& s, std::size_t i) { return &Scope::item(s, i).loc; };
  return key;
}

/// A list inside an item of a nested list; its items' keys get nested2Index(parent, i).
template <class Scope>
Key nested2List(const char* path) {
  Key key(path, KeyType::List);
  key.def.count = [](const SceneSpec& s, std::size_t parent) { return Scope::list(s, parent).size(); };
  key.def.resize = [](SceneSpec& s, std::size_t parent, std::size_t n) { Scope::list(s, parent).resize(n); };
  key.def.item_index = [](std::size_t parent, std::size_t i) { return nested2Index(parent, i); };
  key.def.loc = [](SceneSpec& s, std::size_t i) { return &Scope::item(s, i).loc; };
  return key;
}

// ---------------------------------------------------------------------------------------------
// The table
// ---------------------------------------------------------------------------------------------

std::vector<KeyDef> buildTable() {
  std::vector<KeyDef> t;
  auto add = [&t](const Key& key) { t.push_back(key.def); };
  // The rows every cloth or soft-body anchor takes after its type's own (`p`: "cloth[].anchors" or
  // "soft_bodies[].anchors"): the box of type box, then a constant motion or keyframes.
  auto addAnchorMotion = [&add](auto anchors, auto keys, const std::string& p, const char* keyframes_doc) {
    using A = decltype(anchors);
    using K = decltype(keys);
    add(field<A>((p + "[].min").c_str(), [](auto& a) -> auto& { return a.min; })
            .unit("m").doc("type box: lower corner, world frame (the box must hold at least one node)"));
    add(field<A>((p + "[].max").c_str(), [](auto& a) -> auto& { return a.max; })
            .unit("m").doc("type box: upper corner, world frame"));
    add(field<A>((p + "[].velocity").c_str(), [](auto& a) -> auto& { return a.velocity; })
            .unit("m/s").doc("velocity of the anchored nodes until stop (0: fixed)"));
    add(field<A>((p + "[].stop").c_str(), [](auto& a) -> auto& { return a.stop; })
            .unit("s").atLeast(0).allowInfinity().doc("the anchored nodes stop moving at this time; .inf = never"));
    add(nested2List<K>((p + "[].keyframes").c_str()).defaultNote("[]").doc(keyframes_doc));
    add(field<K>((p + "[].keyframes[].time").c_str(), [](auto& k) -> auto& { return k.time; })
            .unit("s").atLeast(0).required().doc("time of this key, strictly greater than the previous key's"));
    add(field<K>((p + "[].keyframes[].offset").c_str(), [](auto& k) -> auto& { return k.offset; })
            .unit("m").required().doc("displacement of the anchored nodes from where they were placed, world frame"));
  };

  // simulation: time stepping and numerics ---------------------------------------------------
  add(section("simulation", [](SceneSpec& s) { return &s.simulation.loc; }).doc("time stepping and numerics"));
  add(field<InScene>("simulation.duration", [](auto& s) -> auto& { return s.simulation.duration; })
          .unit("s").greaterThan(0).doc("simulated time to run"));
  add(field<InScene>("simulation.frame_rate", [](auto& s) -> auto& { return s.simulation.frame_rate; })
          .unit("1/s").greaterThan(0).doc("output frames per simulated second"));
  add(field<InScene>("simulation.substeps", [](auto& s) -> auto& { return s.simulation.substeps; })
          .unit("1").atLeast(1).doc("time steps per frame before CFL subdivision"));
  add(field<InScene>("simulation.gravity", [](auto& s) -> auto& { return s.simulation.gravity; })
          .unit("m/s^2").doc("gravitational acceleration [x, y, z] (Z is up)"));
  add(field<InScene>("simulation.gravity_ramp", [](auto& s) -> auto& { return s.simulation.gravity_ramp; })
          .unit("s").atLeast(0).doc("gravity ramps from 0 to full over this time; 0 = full from the start"));
  add(field<InScene>("simulation.settle_time", [](auto& s) -> auto& { return s.simulation.settle_time; })
          .unit("s").atLeast(0).doc("before t = 0 the fluid settles this long under gravity (ramped in over the first quarter), "
                                    "its velocities damped, bodies and cloth held: a scene at rest starts at rest, "
                                    "its particles off the blocks' cubic lattice; 0 = start from the lattice"));
  add(field<InScene>("simulation.settle_damping", [](auto& s) -> auto& { return s.simulation.settle_damping; })
          .unit("s").greaterThan(0).doc("time constant of the settle's velocity damping (v *= exp(-dt / this) each step)"));
  add(field<InScene>("simulation.kernel", [](auto& s) -> auto& { return s.simulation.kernel; })
          .doc("smoothing kernel"));
  add(field<InScene>("simulation.support_ratio", [](auto& s) -> auto& { return s.simulation.support_ratio; })
          .unit("1").atLeast(1.5).atMost(4).doc("kernel support radius / particle spacing"));
  add(field<InScene>("simulation.time_step_control", [](auto& s) -> auto& { return s.simulation.time_step_control; })
          .doc("when dt exceeds the CFL limit: subdivide the step, or only warn"));
  add(field<InScene>("simulation.cfl", [](auto& s) -> auto& { return s.simulation.cfl; })
          .unit("1").greaterThan(0).atMost(1).doc("Courant number: dt <= cfl * h / (c0 + |v|max)"));
  add(field<InScene>("simulation.contact_step", [](auto& s) -> auto& { return s.simulation.contact_step; })
          .unit("s").atLeast(0).doc("rigid bodies' contacts and positions in substeps of at most this within each time step, "
                                    "the step's forces applied once; 0 = one contact solve per step. At long steps "
                                    "(DFSPH's ms steps, a rigid-only scene's frame substeps) one solve per step damps "
                                    "rolling: a ball in a bowl at 1/120 s swings 16 % slow and stops in ~1.5 s; "
                                    "0.0005 restores the rolling period (docs/forces.md, session 40)"));
  add(field<InScene>("simulation.numerical_errors", [](auto& s) -> auto& { return s.simulation.numerical_errors; })
          .doc("policy for NaN, escaping particles and CFL violations"));

  // domain: the simulation box and its walls -------------------------------------------------
  add(section("domain", [](SceneSpec& s) { return &s.domain.loc; }).doc("the simulation box and its walls"));
  add(field<InScene>("domain.min", [](auto& s) -> auto& { return s.domain.min; })
          .unit("m").required().doc("lower corner of the domain box"));
  add(field<InScene>("domain.max", [](auto& s) -> auto& { return s.domain.max; })
          .unit("m").required().doc("upper corner of the domain box (> min in every component)"));
  add(section("domain.closed", nullptr).doc("which walls are closed (boundary particles behind them)"));
  add(field<InScene>("domain.closed.x_min", [](auto& s) -> auto& { return s.domain.closed[XMin]; })
          .doc("wall at x = min.x is closed"));
  add(field<InScene>("domain.closed.x_max", [](auto& s) -> auto& { return s.domain.closed[XMax]; })
          .doc("wall at x = max.x is closed"));
  add(field<InScene>("domain.closed.y_min", [](auto& s) -> auto& { return s.domain.closed[YMin]; })
          .doc("wall at y = min.y is closed"));
  add(field<InScene>("domain.closed.y_max", [](auto& s) -> auto& { return s.domain.closed[YMax]; })
          .doc("wall at y = max.y is closed"));
  add(field<InScene>("domain.closed.z_min", [](auto& s) -> auto& { return s.domain.closed[ZMin]; })
          .doc("wall at z = min.z (floor) is closed"));
  add(field<InScene>("domain.closed.z_max", [](auto& s) -> auto& { return s.domain.closed[ZMax]; })
          .doc("wall at z = max.z (ceiling) is closed"));
  add(field<InScene>("domain.boundary_layers", [](auto& s) -> auto& { return s.domain.boundary_layers; })
          .unit("1").atLeast(1).atMost(4).doc("layers of boundary particles behind each closed wall"));

  // fluid: particles, material model, phases, initial blocks and inflows ----------------------
  add(section("fluid", [](SceneSpec& s) { return &s.fluid.loc; }).doc("fluid model, phases, blocks and inflows"));
  add(field<InScene>("fluid.solver", [](auto& s) -> auto& { return s.fluid.solver; })
          .doc("pressure solver: wcsph (weakly compressible, equation of state) or dfsph (divergence-free SPH, "
               "Bender & Koschier 2017: incompressible at large adaptive steps)"));
  add(section("fluid.dfsph", [](SceneSpec& s) { return &s.fluid.dfsph.loc; })
          .doc("settings of the dfsph solver (used with fluid.solver: dfsph)"));
  add(field<InScene>("fluid.dfsph.density_error", [](auto& s) -> auto& { return s.fluid.dfsph.density_error; })
          .unit("1").greaterThan(0).atMost(0.1)
          .doc("bound on the average density error (rho - rho0) / rho0 at the end of each step (5e-4 = 0.05 %)"));
  add(field<InScene>("fluid.dfsph.divergence_error", [](auto& s) -> auto& { return s.fluid.dfsph.divergence_error; })
          .unit("1").greaterThan(0).atMost(0.1)
          .doc("bound on the average density change over one step, dt (D rho / Dt) / rho0 (1e-3 = 0.1 %)"));
  add(field<InScene>("fluid.dfsph.min_iterations", [](auto& s) -> auto& { return s.fluid.dfsph.min_iterations; })
          .unit("1").atLeast(0).doc("density solve: iterations at least"));
  add(field<InScene>("fluid.dfsph.max_iterations", [](auto& s) -> auto& { return s.fluid.dfsph.max_iterations; })
          .unit("1").atLeast(1).atMost(10000)
          .doc("density solve: iterations at most (>= min_iterations); a step that stops here is a counted warning"));
  add(field<InScene>("fluid.dfsph.divergence_min_iterations", [](auto& s) -> auto& { return s.fluid.dfsph.divergence_min_iterations; })
          .unit("1").atLeast(0).doc("divergence solve: iterations at least"));
  add(field<InScene>("fluid.dfsph.divergence_max_iterations", [](auto& s) -> auto& { return s.fluid.dfsph.divergence_max_iterations; })
          .unit("1").atLeast(1).atMost(10000).doc("divergence solve: iterations at most (>= divergence_min_iterations)"));
  add(field<InScene>("fluid.dfsph.divergence_solve", [](auto& s) -> auto& { return s.fluid.dfsph.divergence_solve; })
          .doc("make the velocity field divergence-free each step (Bender & Koschier 2017, Alg. 2)"));
  add(field<InScene>("fluid.dfsph.walls", [](auto& s) -> auto& { return s.fluid.dfsph.walls; })
          .doc("mirrored: walls mirror the fluid's pressure (p_b = p_i), Jacobi increments >= 0, half the last "
               "pressure as warm start (right pressure at walls; more iterations); single: Akinci's single wall "
               "term, pressures projected to >= 0, the full last pressure as warm start (the reference "
               "implementation's; ~2.4x fewer iterations, the first fluid layer at a wall reads ~1.7x its pressure); "
               "extrapolated (the default): the wall's pressure extrapolated from the fluid (Adami et al. 2012 eq. 27, "
               "as WCSPH's walls) in each iteration of single's solve (right pressure next to walls and on bodies, "
               "Archimedes draft 2.4 %, ~2 wall crossings where the others have ~140; at rest the pressure rings "
               "within what the density bound cannot see: docs/dfsph.md)"));
  add(field<InScene>("fluid.dfsph.warm_start", [](auto& s) -> auto& { return s.fluid.dfsph.warm_start; })
          .doc("start each solve from the pressure of the previous step (where the flow compresses)"));
  add(field<InScene>("fluid.dfsph.warm_smoothing", [](auto& s) -> auto& { return s.fluid.dfsph.warm_smoothing; })
          .unit("1").atLeast(0).atMost(1)
          .doc("the density solve's warm start (walls single or extrapolated) takes the last pressure with its "
               "particle-scale part, its deviation from the neighbours' Shepard average (the hydrostatic part kept "
               "exactly), scaled by 1 - beta. Restarted in full (0, the default), that part pushes each particle "
               "with the last step's error a step late: a calm shallow tub with little viscosity kept moving at 7x "
               "the iterations, and 0.5 calms it (the live stirring tub 1.7x faster, 2.1x with plain Jacobi). Alone "
               "it let a narrow column at rest swing (a tank 6 cm wide and 20 cm deep at 3.33 ms steps) and a 28 cm "
               "deep tank with a sinking ball blow up at the ball's landing; with warm_average 0.5 both stay stable. "
               "Neighbours of the same phase only. Off by default: at tight density bounds it costs iterations "
               "(docs/dfsph.md, sessions 28 and 29)"));
  add(field<InScene>("fluid.dfsph.warm_average", [](auto& s) -> auto& { return s.fluid.dfsph.warm_average; })
          .unit("1").atLeast(0).atMost(1)
          .doc("the density solve's warm start (walls single or extrapolated) averaged over the last two steps: "
               "p + gamma (p_prev - p). What the last solve added for its own step's error, which a full restart "
               "applies a second time, enters at 1 - gamma; what every step needs (a column's weight, a body at "
               "rest) is in both steps. With warm_smoothing 0.5 it keeps the narrow tank and the sinking ball's "
               "landing stable where warm_smoothing alone did not (docs/dfsph.md, session 29); 0 = the last "
               "pressure alone"));
  add(field<InScene>("fluid.dfsph.warm_average_rest", [](auto& s) -> auto& { return s.fluid.dfsph.warm_average_rest; })
          .unit("1").atLeast(0).atMost(1)
          .doc("warm_average's gamma in the density solves of steps at rest (the fastest particle moved less than "
               "coarse_rest_travel spacings in the last step; the larger of the two applies). Restarted in full at "
               "rest, the last solve's push for its own error returns a step late as a period-2 swing that the "
               "default bound leaves in place: a 0.2 m tank at rest rang by up to 3.7 kPa between steps in half of "
               "48 runs with small changes to its settings, and was calm in all 48 with 0.6, in fewer iterations "
               "(and at the bound 1e-5 converged in every step where 0 and 0.75 did not always). Moving flows keep "
               "the full restart (an averaged one cost the 50k dam break 6 % more iterations per step). It takes "
               "margin from the pressure's own step scale: a deep column under pressure_cfl 0.7 swung with it, under "
               "0.5 (the default) it rests; "
               "0 = off (docs/dfsph.md, session 47)"));
  add(field<InScene>("fluid.dfsph.relaxation", [](auto& s) -> auto& { return s.fluid.dfsph.relaxation; })
          .unit("1").greaterThan(0).atMost(1)
          .doc("Jacobi relaxation omega of the pressure updates (the reference implementation's 0.5)"));
  add(field<InScene>("fluid.dfsph.chebyshev", [](auto& s) -> auto& { return s.fluid.dfsph.chebyshev; })
          .unit("1").atLeast(0).lessThan(1)
          .doc("Chebyshev semi-iteration on the density solve's relaxed Jacobi iterates (Golub & Varga 1961; Wang "
               "2015): the estimated spectral radius rho of the relaxed iteration. After the first iteration each "
               "iterate is x_{k-1} + w_k (x_jacobi - x_{k-1}), w_2 = 2 / (2 - rho^2), w_{k+1} = 4 / (4 - rho^2 w_k), "
               "projected on p >= 0; a coarse correction restarts the sequence. Moving steps only (the fastest "
               "particle moved at least 0.1 dx in the last step): a step at rest keeps plain Jacobi and the two-level "
               "solve. 0 = off (docs/dfsph.md, session 48)"));
  add(field<InScene>("fluid.dfsph.divergence_chebyshev", [](auto& s) -> auto& { return s.fluid.dfsph.divergence_chebyshev; })
          .unit("1").atLeast(0).lessThan(1)
          .doc("the same Chebyshev semi-iteration for the divergence solve (moving steps only); 0 = off"));
  add(field<InScene>("fluid.dfsph.viscosity_solve", [](auto& s) -> auto& { return s.fluid.dfsph.viscosity_solve; })
          .doc("the laminar viscosity (fluid.viscosity_model: laminar) explicit, whose step is bound by "
               "0.125 h^2 / nu (Morris et al. 1997), or implicit: each step solves backward Euler, (I - dt L) v' = w, "
               "L Morris' viscous operator with the boundaries' velocities of the step, w the velocities with the "
               "last density pressure and gravity applied (an incremental pressure correction: a steady Stokes flow "
               "is kept at any step), by preconditioned conjugate gradients on the device in a fixed order, and the "
               "step is no longer bound by the viscosity (a towed ball in syrup: the drag within 1-5 % of the "
               "explicit solve's at 4-20x its step; docs/dfsph.md, session 36). The bodies take the reaction of "
               "the same viscous forces; free rigid bodies and cloth and soft-body nodes are unknowns of the solve "
               "(session 38). Cloth, and soft bodies lighter than the liquid, need their xpbd step split into "
               "substeps of at most 0.5 ms (their automatic max_time_step chooses it; a longer one is refused: in "
               "one step light sheets swung or blew up in syrup), and free bodies body_coupling: strong "
               "(docs/dfsph.md, session 38). auto (the default): implicit where the explicit bound is shorter than "
               "fluid.dfsph.max_time_step (viscous liquids: nu > 0.125 h^2 / max_time_step, 2.5e-3 m^2/s at h = 1 cm "
               "and 5 ms) and the scene meets those conditions, explicit otherwise; a note says which and why "
               "(session 39)"));
  add(field<InScene>("fluid.dfsph.viscosity_tolerance", [](auto& s) -> auto& { return s.fluid.dfsph.viscosity_tolerance; })
          .unit("1").greaterThan(0).atMost(1)
          .doc("implicit viscosity: the solve stops when its preconditioned residual has fallen to this fraction of "
               "the step's first one (the explicit viscous increment)"));
  add(field<InScene>("fluid.dfsph.viscosity_max_iterations", [](auto& s) -> auto& { return s.fluid.dfsph.viscosity_max_iterations; })
          .unit("1").atLeast(1).atMost(10000)
          .doc("implicit viscosity: conjugate-gradient iterations at most per step (a step that stops here is "
               "counted in the summary and run.json)"));
  add(field<InScene>("fluid.dfsph.coarse_interval", [](auto& s) -> auto& { return s.fluid.dfsph.coarse_interval; })
          .unit("1").atLeast(0).atMost(10000)
          .doc("two-level solve (walls single or extrapolated): a coarse-grid correction of the pressures on "
               "aggregates of one support H (Galerkin operator from the Jacobi pass's pair terms, assembled and "
               "solved by conjugate gradients on the device in a fixed order); it removes the smooth pressure errors "
               "that the average-error stop cannot see (the resting column's ringing, docs/dfsph.md). Applied after "
               "the first iteration of the density solve at rest (coarse_rest_travel: calm at the reference's "
               "density bound) and every n iterations after while it is above its bound (coarse_rest_start), and, with coarse_start k0 > 0, every n iterations of a solve still above its bound "
               "from k0 on; a flow that moves takes none (the dam breaks at plain Jacobi's CPU time but for their "
               "first steps at rest). A solve makes no more corrections once one did not lower its error (the "
               "run's summary counts such solves; docs/dfsph.md, session 13). 0 = off (plain Jacobi)"));
  add(field<InScene>("fluid.dfsph.coarse_start", [](auto& s) -> auto& { return s.fluid.dfsph.coarse_start; })
          .unit("1").atLeast(0).atMost(10000)
          .doc("two-level solve: a solve (density or divergence) still above its bound after this many Jacobi "
               "iterations takes a coarse-grid correction, and another every coarse_interval iterations after "
               "(fewer iterations in moving flows, but a body's force then depends on it at the default density "
               "bound: docs/dfsph.md); 0 = never (the default: only the rest rule, coarse_rest_travel)"));
  add(field<InScene>("fluid.dfsph.coarse_rest_travel", [](auto& s) -> auto& { return s.fluid.dfsph.coarse_rest_travel; })
          .unit("1").atLeast(0)
          .doc("two-level solve: a step whose fastest particle (or body) moved less than this many particle spacings "
               "in the last step is at rest, and its density solve takes a coarse-grid correction after the first "
               "Jacobi iteration (a fluid at rest rings at the default density bound without it; moving flows move "
               "~0.2-0.4 spacings per step at the Courant number 0.4); 0 = never"));
  add(field<InScene>("fluid.dfsph.coarse_reuse", [](auto& s) -> auto& { return s.fluid.dfsph.coarse_reuse; })
          .unit("1").atLeast(0).atMost(1000)
          .doc("two-level solve: an assembled coarse-grid operator serves the corrections of up to this many steps "
               "(of the same solve) while the fastest particle has moved less than 0.25 dx since and the step is "
               "within 25 % of the operator's (its dt^2 scaled); half of a correction's cost is the assembly, so "
               "scenes at rest run faster (docs/dfsph.md, session 24); the results differ from 0 within the "
               "solve's bound; 0 = assembled for every correction"));
  add(field<InScene>("fluid.dfsph.coarse_rest_start", [](auto& s) -> auto& { return s.fluid.dfsph.coarse_rest_start; })
          .unit("1").atLeast(0).atMost(10000)
          .doc("two-level solve: a density solve at rest (coarse_rest_travel) still above its bound after this many "
               "Jacobi iterations takes another coarse-grid correction, and another every coarse_interval iterations "
               "after: tight density bounds at rest converge in few iterations (docs/dfsph.md, session 12); moving "
               "flows take none; 0 = never (one correction per step at rest, as before session 12)"));
  add(field<InScene>("fluid.dfsph.cfl", [](auto& s) -> auto& { return s.fluid.dfsph.cfl; })
          .unit("1").greaterThan(0).atMost(1).doc("Courant number of the adaptive step: dt <= cfl * dx / |v|max; 0.8 "
                                                     "since session 50, twice the reference's 0.4 (docs/dfsph.md)"));
  add(field<InScene>("fluid.dfsph.max_time_step", [](auto& s) -> auto& { return s.fluid.dfsph.max_time_step; })
          .unit("s").greaterThan(0).doc("largest time step; frames end exactly (the last steps of a frame are evened out)"));
  add(field<InScene>("fluid.dfsph.step_iterations", [](auto& s) -> auto& { return s.fluid.dfsph.step_iterations; })
          .unit("1").atLeast(0).atMost(10000)
          .doc("adaptive step from the density solve's work: after a step whose density solve took more than n "
               "iterations the steps are at most 0.9 of its length; after one that took fewer than n / 2 that bound "
               "grows by 1.1 per step (SPlisHSPlasH's \"CFL - iterations\" rule uses n = 10); the CFL, viscous and "
               "max_time_step bounds still apply; for deep or finely resolved columns at rest (it can unsettle a shallow "
               "tank: docs/dfsph.md, session 14); 0 = off"));
  add(field<InScene>("fluid.dfsph.pressure_cfl", [](auto& s) -> auto& { return s.fluid.dfsph.pressure_cfl; })
          .unit("1").atLeast(0).atMost(10)
          .doc("step bound from the largest pressure: dt <= pressure_cfl * dx / sqrt(max p_i / rho_i) (the last "
               "step's pressures): the pressure drives the particle lattice's own modes, which the density solve "
               "does not hold, so a deep column at rest bounces at long steps (from dt sqrt(g H) / dx ~ 0.9, "
               "measured: docs/dfsph.md, session 15); 0.7 holds deep columns at rest; 0.5 by default since session 50 "
               "(with cfl 0.8 a 28 cm tank filling under its gravity ramp blew up without it, and the warm start "
               "averaged at rest needs the margin below 0.7); 0 = off"));
  add(field<InScene>("fluid.dfsph.body_added_mass", [](auto& s) -> auto& { return s.fluid.dfsph.body_added_mass; })
          .unit("1").atLeast(0).atMost(10)
          .doc("fictitious mass C rho0 V of each dynamic body in its translation, (m + M) a_n = F_n + M a_{n-1} "
               "(Baek & Karniadakis 2012): the incompressible solve answers a body's motion one step late, so a body "
               "lighter than its added mass (e.g. 500 kg/m^3 in water) swings with period 2 steps and grows; 1/2, a "
               "sphere's added mass, makes it stable (docs/forces.md). The fictitious force M (a_{n-1} - a_n) counts "
               "in the body's fluid force, and the fluid within H of the body takes its reaction, so momentum is "
               "conserved; a body with no fluid within H has none. The rotation takes the inertia (M / m) I the same "
               "way (a light spoon turning in water swung up otherwise; its torque's reaction is not given back, its "
               "sum over a run is one step's worth); 0 = off (the plain update)"));
  add(field<InScene>("fluid.dfsph.cloth_coupling", [](auto& s) -> auto& { return s.fluid.dfsph.cloth_coupling; })
          .doc("strong (the default): the free cloth and soft-body nodes move under the pressure inside each "
               "iteration of both solves and every fluid particle's residual counts their motion (as Gissler et "
               "al. 2019 couple rigid bodies), so fluid and nodes meet the density constraint together; a node "
               "with water on both sides moves as its mass, one with water on one side with its springs implicit "
               "(kernels/dfsph.cl). staggered: the nodes answer the solves' pressure only in the cloth's step "
               "after; a light sheet between two water layers then swings with period 2 steps and blows up "
               "(scenes/balls_on_cloth.yaml at 0.043 s; docs/dfsph.md, session 17). Walls: mirrored is always "
               "staggered"));
  add(field<InScene>("fluid.dfsph.body_coupling", [](auto& s) -> auto& { return s.fluid.dfsph.body_coupling; })
          .doc("strong (the default since session 26) or staggered. staggered: a dynamic body answers the solves' "
               "pressure in its own step after them, with the fictitious mass body_added_mass against the added-mass "
               "instability (cheaper per step; a light floating body's force swings ~20x more). strong: "
               "each free dynamic body moves under the current pressures inside every iteration of both solves "
               "(its force and torque summed on the device, its acceleration relaxed by 1/2 between iterations), "
               "and every fluid particle's residual counts that motion (Gissler et al. 2019, interlinked rigid-fluid "
               "coupling), so body and fluid meet the density constraint together and body_added_mass is not used; "
               "the density solve sees the body move under gravity and the last step's contact and external "
               "forces too; a body held by the haptic grab moves with the grab's spring-damper implicit (haptics/grab.h). "
               "A light flat body floating free swings with the staggered coupling at long steps "
               "(docs/forces.md, session 23). Walls: mirrored is always staggered"));
  add(field<InScene>("fluid.dfsph.body_error", [](auto& s) -> auto& { return s.fluid.dfsph.body_error; })
          .unit("m/s^2").atLeast(1e-6).atMost(100)
          .doc("with body_coupling strong: each solve goes on (up to its max iterations) until every free body's "
               "acceleration in the iterations is within this of the one the current pressures give, |F / m - a| + "
               "R |I^-1 T - alpha| (R: the body's reach): the average density error alone stops before the pressure "
               "about a body has settled, and the body's force then swings from step to step (docs/forces.md, "
               "session 23)"));
  add(field<InScene>("fluid.dfsph.body_coarse", [](auto& s) -> auto& { return s.fluid.dfsph.body_coarse; })
          .doc("with body_coupling strong and the two-level solve (coarse_interval > 0): each free body's six "
               "degrees of freedom take part in the coarse-grid correction (a rank-6 term per body in the coarse "
               "operator: the aggregates' residual per unit body acceleration times the body's force per unit "
               "aggregate pressure), so a correction moves the body with the pressure it finds and corrections "
               "continue while a body's error is above body_error (kernels/dfsph_coarse.cl; docs/forces.md, session "
               "25); false: corrections see the bodies held and run only while the fluid's own error is above its "
               "bound"));
  add(field<InScene>("fluid.dfsph.cloth_added_mass", [](auto& s) -> auto& { return s.fluid.dfsph.cloth_added_mass; })
          .unit("1").atLeast(0).atMost(10)
          .doc("with strong cloth coupling, in a step the cloth takes in XPBD substeps (cloth[].max_time_step): "
               "each free cloth or soft-body node with fluid within H moves in its own step with an added mass C "
               "rho0 V_k (V_k the fluid volume its boundary particle stands for; less where it has under a tenth "
               "of a full support of fluid; the solves count it too), and the fluid near it takes the momentum "
               "M (v' - v) before the next step's solves (momentum conserved); its weight and its place at rest "
               "are unchanged. A light sheet with water on both sides otherwise flutters with period about 2 "
               "steps at substeps (docs/dfsph.md, session 19); 0 = off"));
  add(field<InScene>("fluid.particle_spacing", [](auto& s) -> auto& { return s.fluid.particle_spacing; })
          .unit("m").greaterThan(0).doc("lattice spacing dx of the fluid particles"));
  add(field<InScene>("fluid.equation_of_state", [](auto& s) -> auto& { return s.fluid.equation_of_state; })
          .doc("pressure from density: linear p = c0^2 (rho - rho0), or Tait"));
  add(field<InScene>("fluid.speed_of_sound", [](auto& s) -> auto& { return s.fluid.speed_of_sound; })
          .unit("m/s").atLeast(0).doc("numerical speed of sound c0; 0 = automatic (10 x the fastest free-fall speed)"));
  add(field<InScene>("fluid.viscosity_model", [](auto& s) -> auto& { return s.fluid.viscosity_model; })
          .doc("artificial (Monaghan alpha) or laminar (phase viscosity)"));
  add(field<InScene>("fluid.artificial_viscosity", [](auto& s) -> auto& { return s.fluid.artificial_viscosity; })
          .unit("1").atLeast(0).doc("Monaghan alpha, used by the artificial model"));
  add(field<InScene>("fluid.body_viscosity", [](auto& s) -> auto& { return s.fluid.body_viscosity; })
          .doc("viscous coupling with moving rigid bodies: fluid (the fluid's own model, e.g. artificial alpha) or physical (the phases' viscosity, laminar form, whatever the fluid's model)"));
  add(field<InScene>("fluid.body_ambient_pressure", [](auto& s) -> auto& { return s.fluid.body_ambient_pressure; })
          .doc("the pressure force on a moving rigid body whose every particle touches fluid (wcsph, and dfsph with walls: extrapolated). auto (the default since session 33): subtract with wcsph, keep with dfsph (its towed ball in Stokes flow under gravity reads a drag that grows with the ambient pressure under either rule, and 4 % under the closed form's band with subtract). subtract: less a reference pressure times the sum over its particles of their pressure force per pascal, which is zero for a closed surface in a continuum but not for the sampled one once the fluid crowds in front of a moving body: with the ambient pressure ~1000 Pa at 8 cm depth that error was a drag ~1.5x a sinking ball's own (docs/forces.md, sessions 32-33). The reference is the least of the body's particles' pressures (each a 10 ms running mean of its wall pressure), brought to the centre's depth with rho0 g, and never above twice the least raw running mean, so it fades to 0 as the body nears a free surface; 0 where any particle is dry. The fluid's own forces are unchanged, so the body's force is no longer exactly the opposite of its reaction on the fluid (the difference is that closure error times the reference). With dfsph the bodies move inside the solves under the plain sum; the correction acts on the force they are integrated with. keep: the plain pair sum, exactly the opposite of the body's reaction on the fluid (the default with wcsph until session 33). No effect with dfsph's mirrored or single walls"));
  add(field<InScene>("fluid.boundary_velocity", [](auto& s) -> auto& { return s.fluid.boundary_velocity; })
          .doc("velocity of wall and body particles in the fluid-boundary viscous term: ghost (no-slip, Adami, Hu & Adams 2012 eq. 22-23: 2 v_wall minus the fluid velocity interpolated at the particle), wall (the wall's or body's own velocity: half the wall shear), or auto (ghost where the term is laminar: viscosity_model laminar, or body particles with body_viscosity physical; wall for the artificial term); with dfsph, auto is ghost at moving bodies whose term is laminar and wall at the walls"));
  add(field<InScene>("fluid.colour_diffusion", [](auto& s) -> auto& { return s.fluid.colour_diffusion; })
          .unit("m^2/s").atLeast(0).doc("colour diffusion coefficient; 0 = none"));
  add(field<InScene>("fluid.clamp_negative_pressure", [](auto& s) -> auto& { return s.fluid.clamp_negative_pressure; })
          .doc("clamp p >= 0 (avoids tensile instability at free surfaces)"));
  add(field<InScene>("fluid.background_pressure", [](auto& s) -> auto& { return s.fluid.background_pressure; })
          .unit("Pa").atLeast(0).doc("wcsph with every domain wall closed (no free surface): a pressure added to the equation of state everywhere (Morris, Fox & Zhu 1997), so that the fluid's pressure stays positive where the flow's own pressure is below the ambient one. SPH's symmetric pressure force is unstable under tension: in a closed box at zero ambient pressure a ball towed in Stokes flow feels 1.32 x 6 pi mu R U, and 2.07 / 2.11 with 1 / 3 kPa here, inside the closed form's bracket (2.04-2.57; docs/forces.md, session 35). It must exceed the flow's largest suction. 0 = none. Not with dfsph (its pressures come from the solve) or an open wall (the fluid would be pushed out)"));
  add(field<InScene>("fluid.max_particles", [](auto& s) -> auto& { return s.fluid.max_particles; })
          .unit("1").atLeast(0).doc("particle budget; 0 = automatic"));

  add(list<InPhases>("fluid.phases")
          .defaultNote("[{name: water}]").doc("fluid phases (materials); blocks and inflows name one"));
  add(field<InPhases>("fluid.phases[].name", [](auto& p) -> auto& { return p.name; })
          .required().doc("unique phase name"));
  add(field<InPhases>("fluid.phases[].rest_density", [](auto& p) -> auto& { return p.rest_density; })
          .unit("kg/m^3").greaterThan(0).doc("rest density rho0"));
  add(field<InPhases>("fluid.phases[].viscosity", [](auto& p) -> auto& { return p.viscosity; })
          .unit("m^2/s").atLeast(0).doc("kinematic viscosity, used by the laminar model"));
  add(field<InPhases>("fluid.phases[].colour", [](auto& p) -> auto& { return p.colour; })
          .unit("1").atLeast(0).atMost(1).doc("linear RGB colour, each component in [0, 1]"));

  add(list<InBlocks>("fluid.blocks").defaultNote("[]").doc("boxes filled with particles at the start"));
  add(field<InBlocks>("fluid.blocks[].phase", [](auto& b) -> auto& { return b.phase; })
          .defaultNote("(first phase)").doc("name of the block's phase"));
  add(field<InBlocks>("fluid.blocks[].min", [](auto& b) -> auto& { return b.min; })
          .unit("m").required().doc("lower corner (inside the domain)"));
  add(field<InBlocks>("fluid.blocks[].max", [](auto& b) -> auto& { return b.max; })
          .unit("m").required().doc("upper corner (> min, inside the domain)"));
  add(field<InBlocks>("fluid.blocks[].velocity", [](auto& b) -> auto& { return b.velocity; })
          .unit("m/s").doc("initial velocity"));

  add(list<InInflows>("fluid.inflows").defaultNote("[]").doc("nozzles that emit particles while active"));
  add(field<InInflows>("fluid.inflows[].name", [](auto& f) -> auto& { return f.name; })
          .doc("label used in messages"));
  add(field<InInflows>("fluid.inflows[].phase", [](auto& f) -> auto& { return f.phase; })
          .defaultNote("(first phase)").doc("name of the emitted phase"));
  add(field<InInflows>("fluid.inflows[].shape", [](auto& f) -> auto& { return f.shape; })
          .doc("nozzle cross-section (circle uses radius, rectangle width and height)"));
  add(field<InInflows>("fluid.inflows[].position", [](auto& f) -> auto& { return f.position; })
          .unit("m").required().doc("nozzle centre (inside the domain)"));
  add(field<InInflows>("fluid.inflows[].direction", [](auto& f) -> auto& { return f.direction; })
          .unit("1").doc("emission direction, nonzero (normalised when compiled)"));
  add(field<InInflows>("fluid.inflows[].radius", [](auto& f) -> auto& { return f.radius; })
          .unit("m").greaterThan(0).doc("circle nozzle radius"));
  add(field<InInflows>("fluid.inflows[].width", [](auto& f) -> auto& { return f.width; })
          .unit("m").greaterThan(0).doc("rectangle nozzle width"));
  add(field<InInflows>("fluid.inflows[].height", [](auto& f) -> auto& { return f.height; })
          .unit("m").greaterThan(0).doc("rectangle nozzle height"));
  add(field<InInflows>("fluid.inflows[].speed", [](auto& f) -> auto& { return f.speed; })
          .unit("m/s").greaterThan(0).doc("emission speed"));
  add(field<InInflows>("fluid.inflows[].start", [](auto& f) -> auto& { return f.start; })
          .unit("s").atLeast(0).doc("emission start time"));
  add(field<InInflows>("fluid.inflows[].stop", [](auto& f) -> auto& { return f.stop; })
          .unit("s").greaterThan(0).allowInfinity().doc("emission stop time (> start); .inf = never"));

  // rigid bodies: meshes and primitives, static, scripted or dynamic -------------------------
  add(list<InBodies>("rigid_bodies").defaultNote("[]")
          .doc("rigid bodies (static, kinematic or dynamic); pose: x_world = position + R(axis, angle) (scale x_body)"));
  add(field<InBodies>("rigid_bodies[].name", [](auto& b) -> auto& { return b.name; })
          .required().doc("unique body name (output files body_<name>_NNNN.obj): letters, digits, '_', '-' and '.', at most 64, not starting with '.'"));
  add(field<InBodies>("rigid_bodies[].shape", [](auto& b) -> auto& { return b.shape; })
          .doc("mesh (uses mesh), sphere (radius), box (size), cylinder and capsule (radius, height; axis = body z)"));
  add(field<InBodies>("rigid_bodies[].mesh", [](auto& b) -> auto& { return b.mesh; })
          .defaultNote("(required for shape mesh)")
          .doc("closed, outward-oriented OBJ file, relative to the scene file; body frame = the file's coordinates"));
  add(field<InBodies>("rigid_bodies[].radius", [](auto& b) -> auto& { return b.radius; })
          .unit("m").greaterThan(0).doc("sphere, cylinder and capsule radius"));
  add(field<InBodies>("rigid_bodies[].size", [](auto& b) -> auto& { return b.size; })
          .unit("m").greaterThan(0).doc("box edge lengths along the body axes (centred on the body origin)"));
  add(field<InBodies>("rigid_bodies[].height", [](auto& b) -> auto& { return b.height; })
          .unit("m").greaterThan(0).doc("cylinder length; capsule distance between its cap centres (along body z)"));
  add(field<InBodies>("rigid_bodies[].position", [](auto& b) -> auto& { return b.position; })
          .unit("m").defaultNote("(required; keyframes: the first key's)")
          .doc("world position of the body origin (the primitive's centre, the mesh's origin); a keyframed body may leave it out; a dynamic body's must lie inside the domain"));
  add(field<InBodies>("rigid_bodies[].orientation_axis", [](auto& b) -> auto& { return b.orientation_axis; })
          .unit("1").doc("axis of the initial rotation, nonzero (normalised when compiled)"));
  add(field<InBodies>("rigid_bodies[].orientation_angle", [](auto& b) -> auto& { return b.orientation_angle; })
          .unit("deg").doc("initial rotation about orientation_axis, right-handed"));
  add(field<InBodies>("rigid_bodies[].scale", [](auto& b) -> auto& { return b.scale; })
          .unit("1").greaterThan(0).doc("uniform scale applied to the shape in the body frame"));
  add(field<InBodies>("rigid_bodies[].density", [](auto& b) -> auto& { return b.density; })
          .unit("kg/m^3").greaterThan(0).defaultNote("(give density or mass)")
          .doc("body density; give exactly one of density and mass"));
  add(field<InBodies>("rigid_bodies[].mass", [](auto& b) -> auto& { return b.mass; })
          .unit("kg").greaterThan(0).defaultNote("(give density or mass)")
          .doc("body mass; give exactly one of density and mass"));
  add(field<InBodies>("rigid_bodies[].dynamic", [](auto& b) -> auto& { return b.dynamic; })
          .doc("true: moved by gravity and forces; false: static, or scripted by motion"));
  add(field<InBodies>("rigid_bodies[].hold_until", [](auto& b) -> auto& { return b.hold_until; })
          .unit("s").atLeast(0)
          .doc("dynamic bodies: held still at the initial pose (the fluid force still measured) until this time, then released from rest; 0 = free from the start"));
  add(field<InBodies>("rigid_bodies[].velocity", [](auto& b) -> auto& { return b.velocity; })
          .unit("m/s").doc("initial velocity of the centre of mass (dynamic bodies)"));
  add(field<InBodies>("rigid_bodies[].angular_velocity", [](auto& b) -> auto& { return b.angular_velocity; })
          .unit("rad/s").doc("initial angular velocity, world frame (dynamic bodies)"));
  add(field<InBodies>("rigid_bodies[].friction", [](auto& b) -> auto& { return b.friction; })
          .unit("1").atLeast(0).doc("Coulomb friction coefficient for contacts"));
  add(field<InBodies>("rigid_bodies[].restitution", [](auto& b) -> auto& { return b.restitution; })
          .unit("1").atLeast(0).atMost(1).doc("coefficient of restitution for contacts"));
  add(field<InBodies>("rigid_bodies[].colour", [](auto& b) -> auto& { return b.colour; })
          .unit("1").atLeast(0).atMost(1).doc("linear RGB colour, each component in [0, 1]"));
  add(field<InBodies>("rigid_bodies[].grabbable", [](auto& b) -> auto& { return b.grabbable; })
          .doc("the haptic device may grab this body"));
  add(field<InBodies>("rigid_bodies[].cutter", [](auto& b) -> auto& { return b.cutter; })
          .doc("a blade (a scalpel): every cloth spring whose segment crosses the body's surface breaks for good"));
  add(section("rigid_bodies[].motion", nullptr).doc("scripted motion: makes a non-dynamic body kinematic"));
  add(field<InBodies>("rigid_bodies[].motion.type", [](auto& b) -> auto& { return b.motion.type; })
          .doc("none (static), constant (constant velocity and angular velocity) or keyframes (a C1 path through keyframes)"));
  add(field<InBodies>("rigid_bodies[].motion.velocity", [](auto& b) -> auto& { return b.motion.velocity; })
          .unit("m/s").doc("velocity of the centre of mass (type constant)"));
  add(field<InBodies>("rigid_bodies[].motion.angular_velocity", [](auto& b) -> auto& { return b.motion.angular_velocity; })
          .unit("rad/s").doc("angular velocity about the centre of mass, world frame (type constant)"));
  add(nestedList<InKeyframes>("rigid_bodies[].motion.keyframes").defaultNote("[]")
          .doc("type keyframes: at least 2 poses of the body origin, times strictly increasing; position by a cubic "
               "Hermite (Catmull-Rom) curve, orientation by a C1 quaternion Hermite curve; velocity 0 at the first and "
               "last keys; the first pose is held before, the last after"));
  add(field<InKeyframes>("rigid_bodies[].motion.keyframes[].time", [](auto& k) -> auto& { return k.time; })
          .unit("s").atLeast(0).required().doc("time of this key (greater than the previous key's)"));
  add(field<InKeyframes>("rigid_bodies[].motion.keyframes[].position", [](auto& k) -> auto& { return k.position; })
          .unit("m").required().doc("world position of the body origin at this key (as rigid_bodies[].position)"));
  add(field<InKeyframes>("rigid_bodies[].motion.keyframes[].orientation_axis", [](auto& k) -> auto& { return k.orientation_axis; })
          .unit("1").defaultNote("(the body's orientation_axis)")
          .doc("orientation at this key: rotation axis, nonzero; without axis and angle the key takes the body's orientation"));
  add(field<InKeyframes>("rigid_bodies[].motion.keyframes[].orientation_angle", [](auto& k) -> auto& { return k.orientation_angle; })
          .unit("deg").defaultNote("(the body's orientation_angle)")
          .doc("orientation at this key: angle about orientation_axis; consecutive keys turn the short way (< 180 deg)"));

  // cloth: anchored mass-spring nets (core/cloth.h) ------------------------------------------
  add(list<InCloths>("cloth").defaultNote("[]")
          .doc("cloths: rectangular (or OBJ mesh) mass-spring nets (stretch, shear, bend springs); x_world = position + R(axis, angle) x_cloth"));
  add(field<InCloths>("cloth[].name", [](auto& c) -> auto& { return c.name; })
          .required().doc("unique cloth name (output files cloth_<name>_NNNN.obj)"));
  add(field<InCloths>("cloth[].width", [](auto& c) -> auto& { return c.width; })
          .unit("m").greaterThan(0).doc("extent along the cloth x axis (a chain along y: the strip width, for its mass)"));
  add(field<InCloths>("cloth[].length", [](auto& c) -> auto& { return c.length; })
          .unit("m").greaterThan(0).doc("extent along the cloth y axis"));
  add(field<InCloths>("cloth[].resolution_x", [](auto& c) -> auto& { return c.resolution_x; })
          .unit("1").atLeast(1).doc("nodes along x (1 = a chain along y); node spacing width / (resolution_x - 1)"));
  add(field<InCloths>("cloth[].resolution_y", [](auto& c) -> auto& { return c.resolution_y; })
          .unit("1").atLeast(1).doc("nodes along y (1 = a chain along x); node spacing length / (resolution_y - 1)"));
  add(field<InCloths>("cloth[].position", [](auto& c) -> auto& { return c.position; })
          .unit("m").doc("world position of the cloth centre"));
  add(field<InCloths>("cloth[].orientation_axis", [](auto& c) -> auto& { return c.orientation_axis; })
          .unit("1").doc("axis of the rotation from the cloth frame (cloth in its xy plane), nonzero"));
  add(field<InCloths>("cloth[].orientation_angle", [](auto& c) -> auto& { return c.orientation_angle; })
          .unit("deg").doc("rotation about orientation_axis, right-handed"));
  add(field<InCloths>("cloth[].areal_density", [](auto& c) -> auto& { return c.areal_density; })
          .unit("kg/m^2").greaterThan(0).doc("mass per area; every node carries areal_density width length / nodes"));
  add(field<InCloths>("cloth[].stretch_stiffness", [](auto& c) -> auto& { return c.stretch_stiffness; })
          .unit("N/m").greaterThan(0).doc("spring constant of each stretch spring (grid neighbours)"));
  add(field<InCloths>("cloth[].shear_stiffness", [](auto& c) -> auto& { return c.shear_stiffness; })
          .unit("N/m").atLeast(0).doc("spring constant of each shear spring (cell diagonals); 0 = none"));
  add(field<InCloths>("cloth[].bend_stiffness", [](auto& c) -> auto& { return c.bend_stiffness; })
          .unit("N/m").atLeast(0).doc("spring constant of each bend spring (nodes two apart); 0 = none"));
  add(field<InCloths>("cloth[].damping", [](auto& c) -> auto& { return c.damping; })
          .unit("N s/m").atLeast(0).doc("dashpot along every spring (relative velocity along it)"));
  add(field<InCloths>("cloth[].air_damping", [](auto& c) -> auto& { return c.air_damping; })
          .unit("1/s").atLeast(0).doc("drag on every node: dv/dt = -air_damping v"));
  add(field<InCloths>("cloth[].solver", [](auto& c) -> auto& { return c.solver; })
          .doc("xpbd: XPBD distance constraints (Macklin 2016), graph-coloured Gauss-Seidel, stable at any stiffness; "
               "explicit: mass-spring, symplectic Euler, steps subdivided below the 2 sqrt(m/k) limit"));
  add(field<InCloths>("cloth[].iterations", [](auto& c) -> auto& { return c.iterations; })
          .unit("1").atLeast(1).atMost(1000).doc("xpbd: Gauss-Seidel sweeps over all springs per time step"));
  add(field<InCloths>("cloth[].max_time_step", [](auto& c) -> auto& { return c.max_time_step; })
          .unit("s").atLeast(0).allowInfinity()
          .doc(kXpbdMaxTimeStepDoc));
  add(field<InCloths>("cloth[].tear_strain", [](auto& c) -> auto& { return c.tear_strain; })
          .unit("1").greaterThan(0).allowInfinity().doc("a spring breaks for good when its strain (L - L0) / L0 exceeds this; .inf = never"));
  add(field<InCloths>("cloth[].prestrain", [](auto& c) -> auto& { return c.prestrain; })
          .unit("1").atLeast(0).atMost(1).doc("the cloth is placed stretched: every spring's rest length is its placed length / (1 + prestrain) "
                                             "(skin's natural tension, which makes a cut gape)"));
  add(field<InCloths>("cloth[].colour", [](auto& c) -> auto& { return c.colour; })
          .unit("1").atLeast(0).atMost(1).doc("linear RGB colour, each component in [0, 1]"));
  add(field<InCloths>("cloth[].mesh", [](auto& c) -> auto& { return c.mesh; })
          .doc("OBJ triangle mesh (relative to the scene file) instead of the rectangle: nodes at its vertices (placed by "
               "position / orientation), mass areal_density x a third of the adjacent triangles' area, stretch springs "
               "along edges, bend springs across interior edges; every edge in at most 2 triangles"));
  add(nestedList<InAnchors>("cloth[].anchors").defaultNote("[]")
          .doc("pinned nodes (infinite mass), moving at a constant velocity or along keyframes"));
  add(field<InAnchors>("cloth[].anchors[].type", [](auto& a) -> auto& { return a.type; })
          .doc("corners (the four corners; the two ends of a chain), edge (one edge), node (i, j) or box (nodes inside min..max)"));
  add(field<InAnchors>("cloth[].anchors[].edge", [](auto& a) -> auto& { return a.edge; })
          .doc("type edge: the edge of the rectangle, in the cloth frame: x_min, x_max, y_min or y_max (z_min and z_max are "
               "for soft bodies)"));
  add(field<InAnchors>("cloth[].anchors[].i", [](auto& a) -> auto& { return a.i; })
          .unit("1").atLeast(0).doc("type node: node index along the cloth x axis, 0 .. resolution_x - 1 (mesh cloth: the vertex index, 0-based)"));
  add(field<InAnchors>("cloth[].anchors[].j", [](auto& a) -> auto& { return a.j; })
          .unit("1").atLeast(0).doc("type node: node index along the cloth y axis, 0 .. resolution_y - 1"));
  addAnchorMotion(InAnchors{}, InAnchorKeys{}, "cloth[].anchors",
                  "instead of velocity / stop: at least 1 key; the nodes' offset from their placed position is linear "
                  "in time between keys, held before the first and after the last");
  // soft_bodies: volumetric lattices of springs (core/cloth.h, softLattice) ---------------------
  add(list<InSoftBodies>("soft_bodies").defaultNote("[]")
          .doc("soft bodies: a box (or closed OBJ mesh) filled with a cubic lattice of nodes joined by springs along every "
               "cell's edges, face and body diagonals; x_world = position + R(axis, angle) x_body"));
  add(field<InSoftBodies>("soft_bodies[].name", [](auto& b) -> auto& { return b.name; })
          .required().doc("unique soft body name (output files soft_<name>_NNNN.obj, a row in soft.csv)"));
  add(field<InSoftBodies>("soft_bodies[].size", [](auto& b) -> auto& { return b.size; })
          .unit("m").greaterThan(0).doc("box extents along the body axes (each rounded to whole lattice cells by "
                                         "adjusting the spacing per axis); not used with mesh"));
  add(field<InSoftBodies>("soft_bodies[].position", [](auto& b) -> auto& { return b.position; })
          .unit("m").doc("world position of the body centre (the box's centre; the mesh's origin)"));
  add(field<InSoftBodies>("soft_bodies[].orientation_axis", [](auto& b) -> auto& { return b.orientation_axis; })
          .unit("1").doc("axis of the rotation from the body frame, nonzero"));
  add(field<InSoftBodies>("soft_bodies[].orientation_angle", [](auto& b) -> auto& { return b.orientation_angle; })
          .unit("deg").doc("rotation about orientation_axis, right-handed"));
  add(field<InSoftBodies>("soft_bodies[].spacing", [](auto& b) -> auto& { return b.spacing; })
          .unit("m").atLeast(0).defaultNote("0 (the fluid's particle_spacing)")
          .doc("lattice cell size; 0 = the fluid's particle_spacing dx (keep it <= dx against leaks)"));
  add(field<InSoftBodies>("soft_bodies[].density", [](auto& b) -> auto& { return b.density; })
          .unit("kg/m^3").greaterThan(0).doc("mass per volume; each cell's mass is lumped an eighth to each corner node"));
  add(field<InSoftBodies>("soft_bodies[].young_modulus", [](auto& b) -> auto& { return b.young_modulus; })
          .unit("Pa").greaterThan(0).doc("Young's modulus E; per cell of side a: k = 0.14 E a on edges, 0.12 E a on face and "
                                          "body diagonals (isotropic, Poisson ratio 1/4)"));
  add(field<InSoftBodies>("soft_bodies[].damping", [](auto& b) -> auto& { return b.damping; })
          .unit("s").atLeast(0).doc("stiffness-proportional (Rayleigh) damping: a dashpot damping x k on every spring "
                                     "(damping ratio damping x omega / 2 for a mode of angular frequency omega)"));
  add(field<InSoftBodies>("soft_bodies[].air_damping", [](auto& b) -> auto& { return b.air_damping; })
          .unit("1/s").atLeast(0).doc("drag on every node: dv/dt = -air_damping v"));
  add(field<InSoftBodies>("soft_bodies[].solver", [](auto& b) -> auto& { return b.solver; })
          .doc("xpbd (default) or explicit, as for cloth"));
  add(field<InSoftBodies>("soft_bodies[].iterations", [](auto& b) -> auto& { return b.iterations; })
          .unit("1").atLeast(1).atMost(1000).doc("xpbd: Gauss-Seidel sweeps over all springs per time step"));
  add(field<InSoftBodies>("soft_bodies[].max_time_step", [](auto& b) -> auto& { return b.max_time_step; })
          .unit("s").atLeast(0).allowInfinity()
          .doc(kXpbdMaxTimeStepDoc));
  add(field<InSoftBodies>("soft_bodies[].tear_strain", [](auto& b) -> auto& { return b.tear_strain; })
          .unit("1").greaterThan(0).allowInfinity().doc("a spring breaks for good when its strain (L - L0) / L0 exceeds this; .inf = never"));
  add(field<InSoftBodies>("soft_bodies[].prestrain", [](auto& b) -> auto& { return b.prestrain; })
          .unit("1").atLeast(0).atMost(1).doc("placed stretched: every spring's rest length is its placed length / (1 + prestrain)"));
  add(field<InSoftBodies>("soft_bodies[].colour", [](auto& b) -> auto& { return b.colour; })
          .unit("1").atLeast(0).atMost(1).doc("linear RGB colour, each component in [0, 1]"));
  add(field<InSoftBodies>("soft_bodies[].mesh", [](auto& b) -> auto& { return b.mesh; })
          .doc("closed (watertight) OBJ mesh (relative to the scene file) instead of the box: the lattice's cells whose "
               "centres lie inside it; size is not used"));
  add(nestedList<InSoftAnchors>("soft_bodies[].anchors").defaultNote("[]")
          .doc("pinned nodes (infinite mass), moving at a constant velocity or along keyframes, as for cloth"));
  add(field<InSoftAnchors>("soft_bodies[].anchors[].type", [](auto& a) -> auto& { return a.type; })
          .doc("corners (the lattice's eight extreme nodes: for each diagonal direction (+-1, +-1, +-1) of the body frame "
               "the node furthest along it; a box's eight corners), edge (a face of the lattice), node (lattice index i, j, k) "
               "or box (nodes inside min..max)"));
  add(field<InSoftAnchors>("soft_bodies[].anchors[].edge", [](auto& a) -> auto& { return a.edge; })
          .doc("type edge: a face of the lattice, body frame (x_min: the nodes of the smallest lattice index along x, ... "
               "z_max: the largest along z)"));
  add(field<InSoftAnchors>("soft_bodies[].anchors[].i", [](auto& a) -> auto& { return a.i; })
          .unit("1").atLeast(0).doc("type node: lattice index along the body x axis, 0 .. cells along x (a box: round(size.x / spacing))"));
  add(field<InSoftAnchors>("soft_bodies[].anchors[].j", [](auto& a) -> auto& { return a.j; })
          .unit("1").atLeast(0).doc("type node: lattice index along the body y axis, 0 .. cells along y"));
  add(field<InSoftAnchors>("soft_bodies[].anchors[].k", [](auto& a) -> auto& { return a.k; })
          .unit("1").atLeast(0).doc("type node: lattice index along the body z axis, 0 .. cells along z (a mesh's lattice: "
                                   "only indices of nodes of cells inside the mesh)"));
  addAnchorMotion(InSoftAnchors{}, InSoftAnchorKeys{}, "soft_bodies[].anchors",
                  "instead of velocity / stop: at least 1 key; offset from the placed position, linear in time between keys");
  // probes: the fluid sampled at points and along vertical gauges -----------------------------
  add(section("probes", [](SceneSpec& s) { return &s.probes.loc; })
          .doc("pressure probes and water-height gauges, sampled into probes.csv (like an experiment's gauges)"));
  add(field<InScene>("probes.rate", [](auto& s) -> auto& { return s.probes.rate; })
          .unit("1/s").atLeast(0).doc("samples per simulated second; 0 = every time step"));
  add(list<InProbePoints>("probes.points").defaultNote("[]")
          .doc("points where pressure, density and velocity are read (Shepard-normalised kernel interpolation)"));
  add(field<InProbePoints>("probes.points[].name", [](auto& p) -> auto& { return p.name; })
          .required().doc("unique name (letters, digits, _ and -): the CSV columns <name>_pressure, ..."));
  add(field<InProbePoints>("probes.points[].position", [](auto& p) -> auto& { return p.position; })
          .unit("m").required().doc("the point, inside the domain"));
  add(list<InGauges>("probes.gauges").defaultNote("[]")
          .doc("vertical lines that read the height of the fluid column standing on their foot"));
  add(field<InGauges>("probes.gauges[].name", [](auto& g) -> auto& { return g.name; })
          .required().doc("unique name (letters, digits, _ and -): the CSV column <name>_height"));
  add(field<InGauges>("probes.gauges[].position", [](auto& g) -> auto& { return g.position; })
          .unit("m").required().doc("foot of the line (e.g. on the floor), inside the domain"));
  add(field<InGauges>("probes.gauges[].length", [](auto& g) -> auto& { return g.length; })
          .unit("m").atLeast(0).doc("length of the line upwards; 0 = up to the domain's top"));

  // output ------------------------------------------------------------------------------------
  add(section("output", [](SceneSpec& s) { return &s.output.loc; }).doc("what to write, and where"));
  add(field<InScene>("output.directory", [](auto& s) -> auto& { return s.output.directory; })
          .defaultNote("(./out/<scene stem>)")
          .doc("output folder, relative to the scene file; --set values are relative to the working directory"));
  add(field<InScene>("output.particles", [](auto& s) -> auto& { return s.output.particles; })
          .doc("write particles.h5part (H5Part, opens in ParaView)"));
  add(field<InScene>("output.step_forces", [](auto& s) -> auto& { return s.output.step_forces; })
          .doc("write forces.csv: the fluid force and torque on each moving body at every time step (bodies.csv has one row per frame)"));
  add(section("output.isosurface", [](SceneSpec& s) { return &s.output.isosurface.loc; })
          .doc("fluid surface per output frame (marching cubes on the device); the section turns it on"));
  add(field<InScene>("output.isosurface.enabled", [](auto& s) -> auto& { return s.output.isosurface.enabled; })
          .defaultNote("true in the section, off without it")
          .doc("mesh the fluid surface each output frame, one mesh per phase"));
  add(field<InScene>("output.isosurface.spacing", [](auto& s) -> auto& { return s.output.isosurface.spacing; })
          .unit("m").atLeast(0).doc("surface grid spacing; 0 = automatic (0.5 x particle spacing)"));
  add(field<InScene>("output.isosurface.iso", [](auto& s) -> auto& { return s.output.isosurface.iso; })
          .unit("1").greaterThan(0).lessThan(1)
          .doc("surface value of the normalised field sum V0 W (1 inside, 0 outside; 0.5 = half a spacing out)"));
  add(field<InScene>("output.isosurface.vertex_colours", [](auto& s) -> auto& { return s.output.isosurface.vertex_colours; })
          .doc("per-vertex colour from the particles' colour field (OBJ 'v x y z r g b')"));
  add(field<InScene>("output.isosurface.obj", [](auto& s) -> auto& { return s.output.isosurface.obj; })
          .doc("write fluid_<phase>_%04d.obj per output frame (world coordinates, Z up, normals)"));
  add(field<InScene>("output.isosurface.vdb", [](auto& s) -> auto& { return s.output.isosurface.vdb; })
          .doc("write the surface field as fluid_%04d.vdb (fog grids 'density' = all phases, 'density_<phase>')"));
  add(field<InScene>("output.isosurface.vdb_level_set", [](auto& s) -> auto& { return s.output.isosurface.vdb_level_set; })
          .doc("also write a narrow-band level set 'surface' into each .vdb (3 voxels each side)"));

  // haptics: a device that grabs grabbable bodies (haptics/, ../shared/haptics.md) ---------------
  add(section("haptics", [](SceneSpec& s) { return &s.haptics.loc; })
          .doc("a haptic device that grabs 'grabbable' bodies; the section turns the haptics stage on"));
  add(field<InScene>("haptics.backend", [](auto& s) -> auto& { return s.haptics.backend; })
          .doc("scripted (the device follows haptics.path), simulated (a hand mass pulled towards haptics.path) or bridge "
               "(UDP on 127.0.0.1 to a running sphaptics-bridge next to the device; run --interactive only)"));
  add(field<InScene>("haptics.scale", [](auto& s) -> auto& { return s.haptics.scale; })
          .unit("1").atLeast(0).doc("workspace mapping x_scene = scale R x_device + offset; 0 = largest domain extent / 0.15 m"));
  add(field<InScene>("haptics.rotation_axis", [](auto& s) -> auto& { return s.haptics.rotation_axis; })
          .unit("1").doc("workspace mapping: axis of R (nonzero)"));
  add(field<InScene>("haptics.rotation_angle", [](auto& s) -> auto& { return s.haptics.rotation_angle; })
          .unit("deg").doc("workspace mapping: angle of R about rotation_axis"));
  add(field<InScene>("haptics.offset", [](auto& s) -> auto& { return s.haptics.offset; })
          .unit("m").defaultNote("(the domain centre)").doc("workspace mapping: scene point of the device origin"));
  add(field<InScene>("haptics.gain", [](auto& s) -> auto& { return s.haptics.gain; })
          .unit("1").greaterThan(0).doc("force gain ('haptic strength'): felt force = gain x coupling force on the body"));
  add(field<InScene>("haptics.stiffness", [](auto& s) -> auto& { return s.haptics.stiffness; })
          .unit("N/m").greaterThan(0).atMost(400).doc("coupling stiffness felt at the hand K_d (the body's spring is K_d / (gain scale))"));
  add(field<InScene>("haptics.damping", [](auto& s) -> auto& { return s.haptics.damping; })
          .unit("N s/m").atLeast(0).atMost(4).doc("coupling damping felt at the hand B_d"));
  add(field<InScene>("haptics.damping_ratio", [](auto& s) -> auto& { return s.haptics.damping_ratio; })
          .unit("1").atLeast(0).doc("damping ratio of the body's coupling spring: B_s = 2 ratio sqrt(K_s m)"));
  add(field<InScene>("haptics.reach", [](auto& s) -> auto& { return s.haptics.reach; })
          .unit("m").greaterThan(0).doc("a button press grabs the nearest grabbable body whose surface is this close to the target"));
  add(field<InScene>("haptics.hold_orientation", [](auto& s) -> auto& { return s.haptics.hold_orientation; })
          .doc("hold a grabbed body's orientation at the grab with an angular spring-damper as stiff and damped as the "
               "grasp coupling; it acts on the body only and is not felt (the device renders force, not torque)"));
  add(field<InScene>("haptics.peak_force", [](auto& s) -> auto& { return s.haptics.peak_force; })
          .unit("N").greaterThan(0).doc("largest force sent to the device (capped by the device's own)"));
  add(field<InScene>("haptics.continuous_force", [](auto& s) -> auto& { return s.haptics.continuous_force; })
          .unit("N").greaterThan(0).doc("limit on the 1 s RMS of the force sent"));
  add(field<InScene>("haptics.ramp_time", [](auto& s) -> auto& { return s.haptics.ramp_time; })
          .unit("s").atLeast(0).doc("start-up ramp of the force"));
  add(field<InScene>("haptics.watchdog", [](auto& s) -> auto& { return s.haptics.watchdog; })
          .unit("s").greaterThan(0).doc("a local model older than this fades the force to 0 over 200 ms"));
  add(field<InScene>("haptics.lowpass", [](auto& s) -> auto& { return s.haptics.lowpass; })
          .unit("Hz").greaterThan(0).doc("cut-off of the one-pole low-pass on the feed-forward force"));
  add(field<InScene>("haptics.passivity", [](auto& s) -> auto& { return s.haptics.passivity; })
          .doc("passivity observer and controller (Hannaford & Ryu 2002)"));
  add(field<InScene>("haptics.servo_rate", [](auto& s) -> auto& { return s.haptics.servo_rate; })
          .unit("Hz").atLeast(100).atMost(10000).doc("servo loop rate"));
  add(field<InScene>("haptics.smoothing", [](auto& s) -> auto& { return s.haptics.smoothing; })
          .doc("servo (first-order hold + coupling + low-pass, default) or rolling_average (the paper's: mean force of the last rolling_window frames)"));
  add(field<InScene>("haptics.rolling_window", [](auto& s) -> auto& { return s.haptics.rolling_window; })
          .unit("1").atLeast(1).atMost(1000).doc("rolling_average: frames averaged (delay (N - 1) / (2 frame_rate))"));
  add(field<InScene>("haptics.hand_mass", [](auto& s) -> auto& { return s.haptics.hand_mass; })
          .unit("kg").greaterThan(0).doc("simulated backend: hand + end-effector mass"));
  add(field<InScene>("haptics.hand_stiffness", [](auto& s) -> auto& { return s.haptics.hand_stiffness; })
          .unit("N/m").atLeast(0).doc("simulated backend: grip spring to the scripted target"));
  add(field<InScene>("haptics.hand_damping", [](auto& s) -> auto& { return s.haptics.hand_damping; })
          .unit("N s/m").atLeast(0).doc("simulated backend: grip damper to the scripted target"));
  add(field<InScene>("haptics.bridge_port", [](auto& s) -> auto& { return s.haptics.bridge_port; })
          .unit("1").atLeast(1).atMost(65535).doc("bridge backend: UDP port on 127.0.0.1 where sphaptics-bridge listens (its --listen)"));
  add(field<InScene>("haptics.listen_port", [](auto& s) -> auto& { return s.haptics.listen_port; })
          .unit("1").atLeast(1).atMost(65535).doc("bridge backend: UDP port on 127.0.0.1 where the simulation listens for device States (the bridge's --send)"));
  add(field<InScene>("haptics.bridge_timeout", [](auto& s) -> auto& { return s.haptics.bridge_timeout; })
          .unit("s").greaterThan(0).atMost(60).doc("bridge backend: no State from the bridge for this long is a device failure (exit 3)"));
  add(list<InPath>("haptics.path").defaultNote("[]").doc("scripted hand path, device frame: line, circle or sine segments; the latest started segment rules, its end is held"));
  add(field<InPath>("haptics.path[].type", [](auto& p) -> auto& { return p.type; }).required().doc("segment kind"));
  add(field<InPath>("haptics.path[].start", [](auto& p) -> auto& { return p.start; }).unit("s").atLeast(0).doc("segment start time"));
  add(field<InPath>("haptics.path[].end", [](auto& p) -> auto& { return p.end; }).unit("s").atLeast(0).doc("segment end time (> start)"));
  add(field<InPath>("haptics.path[].from", [](auto& p) -> auto& { return p.from; }).unit("m").doc("line: start point"));
  add(field<InPath>("haptics.path[].to", [](auto& p) -> auto& { return p.to; }).unit("m").doc("line: end point"));
  add(field<InPath>("haptics.path[].centre", [](auto& p) -> auto& { return p.centre; }).unit("m").doc("circle and sine: centre"));
  add(field<InPath>("haptics.path[].radius", [](auto& p) -> auto& { return p.radius; }).unit("m").greaterThan(0).doc("circle: radius"));
  add(field<InPath>("haptics.path[].axis", [](auto& p) -> auto& { return p.axis; }).unit("1").doc("circle: plane normal (nonzero)"));
  add(field<InPath>("haptics.path[].period", [](auto& p) -> auto& { return p.period; }).unit("s").greaterThan(0).doc("circle: time of one turn"));
  add(field<InPath>("haptics.path[].phase", [](auto& p) -> auto& { return p.phase; }).unit("rad").doc("circle: angle at start"));
  add(field<InPath>("haptics.path[].amplitude", [](auto& p) -> auto& { return p.amplitude; }).unit("m").doc("sine: amplitude vector"));
  add(field<InPath>("haptics.path[].f0", [](auto& p) -> auto& { return p.f0; }).unit("Hz").atLeast(0).doc("sine: frequency at start (linear chirp)"));
  add(field<InPath>("haptics.path[].f1", [](auto& p) -> auto& { return p.f1; }).unit("Hz").atLeast(0).doc("sine: frequency at end"));
  add(list<InWaypoints>("haptics.waypoints").defaultNote("[]").doc("scripted hand path as straight lines between points (used when 'path' is empty)"));
  add(field<InWaypoints>("haptics.waypoints[].time", [](auto& w) -> auto& { return w.time; }).unit("s").atLeast(0).required().doc("time (strictly increasing)"));
  add(field<InWaypoints>("haptics.waypoints[].position", [](auto& w) -> auto& { return w.position; }).unit("m").required().doc("device-frame position"));
  add(list<InButtons>("haptics.buttons").defaultNote("[]").doc("button events; button 0 pressed grabs, released lets go"));
  add(field<InButtons>("haptics.buttons[].time", [](auto& b) -> auto& { return b.time; }).unit("s").atLeast(0).required().doc("time of the event"));
  add(field<InButtons>("haptics.buttons[].button", [](auto& b) -> auto& { return b.button; }).unit("1").atLeast(0).atMost(1).doc("button index"));
  add(field<InButtons>("haptics.buttons[].pressed", [](auto& b) -> auto& { return b.pressed; }).doc("true: pressed, false: released"));
  return t;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Lookups
// ---------------------------------------------------------------------------------------------

const std::vector<KeyDef>& schemaTable() {
  static const std::vector<KeyDef> table = buildTable();  // immutable after first use
  return table;
}

const KeyDef* findKey(const std::string& schema_path) {
  for (const KeyDef& key : schemaTable())
    if (key.path == schema_path) return &key;
  return nullptr;
}

std::vector<const KeyDef*> childKeys(const std::string& parent_path) {
  std::vector<const KeyDef*> children;
  for (const KeyDef& key : schemaTable())
    if (key.parent() == parent_path) children.push_back(&key);
  return children;
}

std::string defaultText(const KeyDef& key) {
  if (!key.default_note.empty()) return key.default_note;
  if (key.required) return "(required)";
  if (!key.isLeaf()) return "";
  // Read the default from default-constructed specs: one default item in each list.
  SceneSpec defaults;
  defaults.fluid.phases.resize(1);
  defaults.fluid.blocks.resize(1);
  defaults.fluid.inflows.resize(1);
  defaults.rigid_bodies.resize(1);
  defaults.rigid_bodies[0].motion.keyframes.resize(1);
  defaults.cloth.resize(1);
  defaults.cloth[0].anchors.resize(1);
  defaults.cloth[0].anchors[0].keyframes.resize(1);
  defaults.soft_bodies.resize(1);
  defaults.soft_bodies[0].anchors.resize(1);
  defaults.soft_bodies[0].anchors[0].keyframes.resize(1);
  defaults.probes.points.resize(1);
  defaults.probes.gauges.resize(1);
  defaults.haptics.path.resize(1);
  defaults.haptics.waypoints.resize(1);
  defaults.haptics.buttons.resize(1);
  const Value value = key.get(defaults, 0);
  if (key.type == KeyType::String) return "\"" + std::get<std::string>(value) + "\"";
  return valueText(value);
}

// ---------------------------------------------------------------------------------------------
// schemaText(): one aligned row per key
// ---------------------------------------------------------------------------------------------

std::string schemaText() {
  struct Row {
    std::string cells[6];
  };
  std::vector<Row> rows;
  rows.push_back({{"KEY", "TYPE", "DEFAULT", "UNIT", "ALLOWED", "DESCRIPTION"}});
  for (const KeyDef& key : schemaTable()) {
    std::string allowed;
    if (key.type == KeyType::Enum) {
      for (const auto& choice : key.choices) allowed += (allowed.empty() ? "" : "|") + choice;
    } else if (key.type == KeyType::Float || key.type == KeyType::Int || key.type == KeyType::Vec3) {
      allowed = key.range.str();
      if (key.type == KeyType::Vec3 && !allowed.empty()) allowed = "each " + allowed;
      if (key.type == KeyType::Float && key.allow_infinity) allowed += allowed.empty() ? "inf ok" : ", inf ok";
    }
    rows.push_back({{key.path, keyTypeName(key.type), defaultText(key), key.unit, allowed, key.doc}});
  }

  // Column widths (the last column, the description, is not padded).
  std::size_t width[5] = {0, 0, 0, 0, 0};
  for (const Row& row : rows)
    for (int c = 0; c < 5; ++c) width[c] = std::max(width[c], row.cells[c].size());

  std::ostringstream out;
  out << "Scene keys (YAML). Units are SI; list items are written as name[] (e.g. fluid.phases[0].name in --set).\n";
  for (const Row& row : rows) {
    std::string line;
    for (int c = 0; c < 5; ++c) line += row.cells[c] + std::string(width[c] - row.cells[c].size() + 2, ' ');
    line += row.cells[5];
    while (!line.empty() && line.back() == ' ') line.pop_back();
    out << line << "\n";
  }
  return out.str();
}

}  // namespace sph::io

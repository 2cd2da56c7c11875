// Force checks of bodies in water (issue 15), shared by the tests (tests/test_forces.cpp) and the
// `bench` table: a buoyant ball released from rest (added mass), the same ball held and free
// (buoyancy of a free body), and a ball towed through a viscous liquid (Stokes drag, sideways
// force). Each runs a small scene of scenes/tests/ and compares with its closed form.
#pragma once

#include <string>
#include <vector>

namespace sph::app {

/// A ball held still until the scene's hold_until, then released from rest
/// (scenes/tests/release_ball.yaml).
struct ReleaseCheck {
  int exit_code = 0;
  std::string message;
  double dx = 0;             ///< particle spacing (unit: m)
  double radius = 0;         ///< ball radius (unit: m)
  double weight = 0;         ///< m g (unit: N)
  double buoyancy = 0;       ///< rho_w g V, V the ball's mesh volume (unit: N)
  double held_force = 0;     ///< mean vertical fluid force over the last 0.1 s of the hold (unit: N)
  double free_force = 0;     ///< mean vertical fluid force over the first `window` s after release (unit: N)
  double a0 = 0;             ///< first vertical acceleration: least-squares slope of v_z over the window (unit: m/s^2)
  double a0_expected = 0;    ///< (rho_w - rho_b) g / (rho_b + rho_w / 2) (unit: m/s^2)
  double a0_no_added_mass = 0;  ///< (rho_w - rho_b) g / rho_b (unit: m/s^2)
  double wall_seconds = 0;   ///< (unit: s)
};

/// Runs `scene` (release_ball.yaml) at spacing dx with the ball's density rho_b (unit: kg/m^3), fitting the
/// acceleration over `window` seconds after the release; `sets` are extra --set overrides.
ReleaseCheck releasedBall(const std::string& scene, double dx, double rho_b, double window,
                          const std::vector<std::string>& sets = {}, const std::string& device = "");

/// A buoyant ball released from rest mid-water, against the same ball held throughout
/// (release_ball.yaml twice, the second with hold_until past the end). Both runs are identical up
/// to the release (deterministic), so the held run's force, interpolated to the free run's step
/// times, carries the tank's ringing (the water column's quarter-wave mode, 4 H / c0 ~ 20 Hz,
/// +-40 % of the buoyancy; it is what hid the first acceleration) and the difference is the force
/// of the ball's own motion: F_free - F_held = -C_m rho V a (drag negligible in the first steps),
/// taken in momentum form, int (F_free - F_held) dt = -C_m rho V v(T) over the window T.
struct ReleaseMassCheck {
  int exit_code = 0;
  std::string message;
  double dx = 0;              ///< (unit: m)
  double radius = 0;          ///< (unit: m)
  double cm = 0;              ///< C_m = -int (F_free - F_held) dt / (rho V v(T)) over the window T (unit: 1)
  double cm_confined = 0;     ///< Lamb's concentric sphere at the nearest wall or surface, as AccelCheck (unit: 1)
  /// a sphere moving normal to the floor at centre height h: the method of images' series
  /// (sphereWallAddedMass), 1/2 (1 + 3/8 (R / h)^3 + ...) (unit: 1)
  double cm_floor = 0;
  /// the same with the gap h - R known to dx/2 (where the sampled ball's and the floor's surfaces
  /// lie): sphereWallAddedMass at h + dx/2 (lo) and h - dx/2 (hi) (unit: 1)
  double cm_floor_lo = 0, cm_floor_hi = 0;
  double a0 = 0;              ///< mean acceleration of the ball over the window: v(T) / T (unit: m/s^2; by momentum,
                              ///< a0 (m + C_m rho V) = mean F_held - m g: the same check as cm, in the issue's terms)
  /// the same expected from the held force over the window: (mean F_held - m g) / (m + C_m rho V),
  /// for C_m from 25 % below 1/2 to 25 % above cm_confined, or cm_floor when the floor is the nearest
  /// boundary (the range, the tolerance of the added-mass checks) (unit: m/s^2)
  double a0_expected_lo = 0, a0_expected_hi = 0;
  double a0_still = 0;        ///< (rho_w - rho_b) g / (rho_b + rho_w / 2): the same in a fluid at rest (unit: m/s^2)
  double held_over_buoyancy = 0;  ///< mean held force over the window / rho g V: the ringing's phase at the release (unit: 1)
  double wall_seconds = 0;    ///< both runs (unit: s)
};

/// The added mass coefficient of a sphere (radius R) moving normal to a plane wall in ideal fluid,
/// its centre at distance h from the wall, by the method of images (Milne-Thomson, Theoretical
/// Hydrodynamics, the image of an axial doublet in a sphere): the sphere's doublet, its image in
/// the wall, that image's image in the sphere (a doublet of strength m (R / c)^3 at the inverse
/// point R^2 / c, c its distance from the centre), and so on; C_m = 1/2 (1 + 3 sum_k m_k / m_0) = 1/2 (1 + 3/8 (R/h)^3
/// + 3/64 (R/h)^6 + ...). 0.5 far from the wall, 0.5 + 3/16 (R/h)^3 to leading order, 0.803 at
/// contact (h = R; finite: J. Appl. Mech. 44, 166, 1977). h_over_r = h / R >= 1 (unit: 1).
double sphereWallAddedMass(double h_over_r);

/// Runs `scene` (release_ball.yaml) at spacing dx, ball density rho_b (unit: kg/m^3), free and
/// held, and fits over `window` seconds after the release.
ReleaseMassCheck releasedBallAddedMass(const std::string& scene, double dx, double rho_b, double window,
                                       const std::vector<std::string>& sets = {}, const std::string& device = "");

/// A kinematic ball shaken along x from rest on a keyframed path (scenes/tests/accel_ball.yaml).
struct AccelCheck {
  int exit_code = 0;
  std::string message;
  double dx = 0;              ///< (unit: m)
  double radius = 0;          ///< (unit: m)
  double accel = 0;           ///< largest |a| of the path (unit: m/s^2)
  double cm = 0;              ///< added-mass coefficient M / (rho V), F_x = -M a - B v at the shaking's frequency (unit: 1)
  double cm_unbounded = 0.5;  ///< potential flow, unbounded fluid (unit: 1)
  double cm_confined = 0;     ///< Lamb (1932, art. 92): in a concentric sphere of radius b (the distance to the nearest wall), (1 + 2 l^3) / (2 (1 - l^3)), l = R / b (unit: 1)
  double damping = 0;         ///< B, the part of the force in phase with -v (unit: N s/m)
  double wall_seconds = 0;    ///< (unit: s)
};

/// Runs `scene` (accel_ball.yaml) at spacing dx: over the keyframed phase (first to last key, whole
/// periods) the fluid force is fitted as F_x = -C_m rho V a - B v at the shaking's frequency (F, a
/// and v projected on its cos and sin).
AccelCheck acceleratedBall(const std::string& scene, double dx, const std::vector<std::string>& sets = {},
                           const std::string& device = "");

/// A ball towed at constant velocity U along x through a closed box of viscous liquid
/// (scenes/tests/stokes_tow.yaml), gravity off.
struct TowCheck {
  int exit_code = 0;
  std::string message;
  double dx = 0;               ///< (unit: m)
  double radius = 0;           ///< (unit: m)
  double speed = 0;            ///< U: the constant motion's, or a keyframed tow's mean speed over the window (unit: m/s)
  double box = 0;              ///< the domain's smallest side (unit: m)
  double mu = 0;               ///< dynamic viscosity rho nu (unit: Pa s)
  double reynolds = 0;         ///< 2 R U / nu (unit: 1)
  double drag = 0;             ///< mean -F_x over the second half of the run (unit: N)
  double stokes = 0;           ///< 6 pi mu R U (unit: N)
  double wall_factor_lo = 0;   ///< Haberman & Sayre 1958 K for a container sphere of the box's volume (unit: 1)
  double wall_factor_hi = 0;   ///< the same for the sphere inscribed in the box (unit: 1)
  /// The drag over 6 pi mu R U expected at this resolution: the no-slip surface of a sampled ball
  /// lies within dx/2 of R (its particles sit dx/2 inside the surface, the fluid's first layer
  /// dx/2 outside), so R_eff in [R - dx/2, R + dx/2]: lo = (R - dx/2) K_lo(R - dx/2) / R,
  /// hi = (R + dx/2) K_hi(R + dx/2) / R, with the two containers of wall_factor_lo/hi (unit: 1).
  double expected_lo = 0;
  double expected_hi = 0;      ///< (unit: 1)
  double side = 0;             ///< largest mean sideways component |F_y|, |F_z| over the window (unit: N)
  double side_y = 0;           ///< |mean F_y| alone, for a tow under gravity (F_z then carries the buoyancy) (unit: N)
  double side_noise = 0;       ///< standard error of that mean, from 6 block means (unit: N)
  double drag_noise = 0;       ///< standard error of the drag's mean, from 6 block means (unit: N)
  double wall_seconds = 0;     ///< (unit: s)
};

/// Haberman & Sayre (1958) wall factor of a sphere (radius R) moving at the centre of a rigid
/// spherical container (radius b), lambda = R / b: F = 6 pi mu R U K with
/// K = (1 - lambda^5) / (1 - 9/4 lambda + 5/2 lambda^3 - 9/4 lambda^5 + lambda^6).
double sphereInSphereWallFactor(double lambda);

/// The radius R_eff of a no-slip sphere whose Stokes drag in a spherical container of radius b (m)
/// is `ratio` x 6 pi mu R U: the root of (R_eff / R) K(R_eff / b) = ratio (bisection over
/// 0.25 R .. min(1.75 R, 0.99 b)). With b the two containers that bracket the box (TowCheck), it
/// places the towed ball's effective no-slip surface (unit: m).
double stokesEffectiveRadius(double ratio, double radius, double b);

/// Runs `scene` (stokes_tow.yaml) at spacing dx; `sets` are extra --set overrides.
TowCheck towedBall(const std::string& scene, double dx, const std::vector<std::string>& sets = {},
                   const std::string& device = "");

/// A dense ball released from rest in still water, sinking (scenes/tests/sink_ball.yaml). Its
/// downward speed against the closed form of a body with added mass and quadratic drag,
/// (m + C_m rho V) dv/dt = (m - rho V) g - 1/2 rho C_d pi R^2 v^2, whose solution from rest is
/// v(t) = v_t tanh(a0 t / v_t), a0 = (m - rho V) g / (m + C_m rho V), v_t = sqrt(2 (m - rho V) g /
/// (rho C_d pi R^2)) (v = a0 t for C_d = 0). The envelope: slowest with the largest C_m and C_d,
/// fastest with the smallest.
struct SinkCheck {
  int exit_code = 0;
  std::string message;
  double dx = 0;              ///< (unit: m)
  double radius = 0;          ///< (unit: m)
  double density = 0;         ///< the ball's (unit: kg/m^3)
  double window = 0;          ///< time free, from the release to the last sample (unit: s)
  double v_end = 0;           ///< downward speed at the end of the window (unit: m/s)
  double v_lo = 0, v_hi = 0;  ///< the closed form's envelope at the end of the window (unit: m/s)
  /// the tank's ringing (the water column's start-up waves; undamped in water at its own
  /// viscosity): over the last 0.1 s of the hold, the swing (largest minus smallest) of
  /// int (F - mean F) dt, divided by m + C_m rho V: the speed it would give the free ball about
  /// the mean, the envelope's margin at every sample (unit: m/s)
  double ringing = 0;
  double worst = 0;           ///< largest distance outside [v_lo - ringing, v_hi + ringing] over the samples up to `until` (unit: m/s)
  double worst_time = 0;      ///< time after the release where it was found (unit: s)
  double above = 0;           ///< largest distance above v_hi + ringing over all samples (unit: m/s)
  /// the mean drag coefficient over the window, from momentum with C_m = 1/2:
  /// C_d = ((m - rho V) g T - (m + rho V / 2) v(T)) / (1/2 rho pi R^2 int v^2 dt) (unit: 1)
  double cd_effective = 0;
  double reynolds = 0;        ///< 2 R v_end / nu (unit: 1)
  /// the ringing margin as a margin on cd_effective: (m + rho V / 2) ringing / (1/2 rho pi R^2 int v^2 dt) (unit: 1)
  double cd_ringing = 0;
  double held_over_buoyancy = 0;  ///< mean force over the last 0.1 s of the hold / rho g V (unit: 1)
  /// sinkingBallHeldDrag only: the mean drag coefficient with the tank's ringing and the sampled
  /// buoyancy taken out, from the same ball held throughout (the two runs are bitwise equal up to the
  /// release): int D dt = int (F_free - F_held) dt - C_m rho V v(T), C_m = 1/2,
  /// C_d = int D dt / (1/2 rho pi R^2 int v^2 dt) (unit: 1)
  double cd_held_subtracted = 0;
  /// sinkingBallHeldDrag only: that impulse split by least squares over every step from `skip` to
  /// the end, I(t) = int_0^t (F_free - F_held) dt = C_m rho V v(t) + C_d 1/2 rho pi R^2 int_0^t v^2 dt
  /// + B x(t), x the distance sunk: the added mass, a quadratic (form) drag and a drag linear in the
  /// speed, which a sphere in water should not have at Re ~ 1e4 (6 pi mu R is 6e-4 N s/m here)
  /// (units: 1, 1, N s/m). Ill-conditioned over one run (the three columns grow together): read
  /// it across resolutions, not as a test.
  double fit_cm = 0, fit_cd = 0, fit_b = 0;
  std::vector<double> t, v, lo, hi;  ///< the samples: time after release (s), speed, envelope (m/s)
  double wall_seconds = 0;    ///< (unit: s)
};

/// The closed form above: speed at time t after the release from rest (unit: m/s), for a body of
/// mass m (kg) and volume V (m^3), radius R (m), in a liquid of density rho (kg/m^3), gravity g (m/s^2).
double sinkingSpeed(double t, double m, double V, double R, double rho, double g, double cm, double cd);

/// Runs `scene` (sink_ball.yaml) at spacing dx; samples every step from `skip` seconds after the
/// release (unit: s) on, against C_m in [cm_lo, cm_hi] and C_d in [cd_lo, cd_hi]: the whole
/// envelope up to `until` seconds after the release, its fast side over the whole run.
SinkCheck sinkingBall(const std::string& scene, double dx, double skip, double until, double cm_lo, double cm_hi,
                      double cd_lo,
                      double cd_hi, const std::vector<std::string>& sets = {}, const std::string& device = "");

/// sinkingBall, and the same scene with the ball held throughout, for SinkCheck::cd_held_subtracted
/// (two runs: the free one and the held one).
SinkCheck sinkingBallHeldDrag(const std::string& scene, double dx, double skip, double until, double cm_lo, double cm_hi,
                              double cd_lo, double cd_hi, const std::vector<std::string>& sets = {},
                              const std::string& device = "");

/// The upper end of a sampled sphere's mean drag coefficient in a tank at Re ~ 1e3 .. 1e5: a
/// sphere's 0.5 (Newton regime; started from rest its wake forms over several diameters, so its
/// mean is lower), times the resolution's (1 + dx / 2R)^2 (the pressure surface of a ball sampled
/// at spacing dx lies within dx/2 of R: form drag scales with the frontal area), times the wall
/// factor of a sphere of diameter d = 2R settling in a tube of diameter D, Munroe's (1888)
/// v_t / v_inf = 1 - (d / D)^1.5 for Re > ~1e3 (Chhabra, Agarwal & Sinha 1999, Powder Technol.
/// 101, 288), so C_d x 1 / (1 - (d/D)^1.5)^2; for a square tank D is its side (the hydraulic
/// diameter: the larger factor). R, dx, D in m (unit: 1).
double sinkingDragBound(double radius, double dx, double tank);

/// Schiller & Naumann (1933): a sphere's drag over Stokes' at Reynolds number Re = 2 R U / nu
/// (Re < ~800), C_D = 24/Re (1 + 0.15 Re^0.687), i.e. F / (6 pi mu R U) = 1 + 0.15 Re^0.687 (unit: 1).
double schillerNaumann(double re);

/// The confinement of a sphere (diameter d) moving along a circular tube (diameter D) at Reynolds
/// number Re, lambda = d / D: Di Felice's (1996, Int. J. Multiphase Flow 22, 527) correlation for
/// the settling velocity, U_t / U_inf = ((1 - lambda) / (1 - 0.33 lambda))^alpha with alpha =
/// (3.3 + 0.085 Re) / (1 + 0.1 Re) (alpha -> 3.3 in Stokes flow: close to Haberman & Sayre's tube
/// factor), turned into a drag factor at the same speed with the local slope of Schiller-Naumann's
/// drag, K = (U_t / U_inf)^-n, n = dln F / dln U (unit: 1).
double diFeliceWallFactor(double lambda, double re);

/// The drag over 6 pi mu R U expected of a ball of radius R (m) sampled at spacing dx (m), towed at
/// U (m/s) through a liquid of kinematic viscosity nu (m^2/s) along a square duct of side `side`
/// (m): (R_eff / R) schillerNaumann(Re_eff) diFeliceWallFactor(d_eff / D, Re_eff), the no-slip
/// surface within R -+ dx/2, the duct between the tube of its cross-section's area and the
/// inscribed tube: lo with R - dx/2 and the equal-area tube, hi with R + dx/2 and the inscribed one.
void moderateReBand(double radius, double dx, double side, double speed, double nu, double& lo, double& hi);

/// The drag over 6 pi mu R U expected of a ball of radius R (m) sampled at spacing dx (m) at the
/// centre of a closed cubic box of side L (m): TowCheck::expected_lo/hi (unit: 1).
void stokesBand(double radius, double dx, double box, double& lo, double& hi);

/// A dense ball falling through a viscous liquid at its terminal velocity (scenes/tests/stokes_fall.yaml):
/// U = (m - rho V) g / (6 pi mu R K), K the box's wall factor, as TowCheck.
struct FallCheck {
  int exit_code = 0;
  std::string message;
  double dx = 0;               ///< (unit: m)
  double radius = 0;           ///< (unit: m)
  double speed = 0;            ///< mean speed along its net weight (down, or up for a ball lighter than the liquid) over the second half of the free time (unit: m/s)
  double speed_stokes = 0;     ///< (m - rho V) g / (6 pi mu R), unbounded (unit: m/s)
  double reynolds = 0;         ///< 2 R U / nu (unit: 1)
  double ratio = 0;            ///< the drag's factor over Stokes: speed_stokes / speed, to compare with the band (unit: 1)
  double expected_lo = 0, expected_hi = 0;  ///< the towed ball's band (stokesBand) (unit: 1)
  /// the same with the buoyancy the liquid gave the ball held (mean force over the last 0.05 s of
  /// the hold) instead of rho g V: at terminal speed the drag is m g - F_held (unit: 1)
  double ratio_held = 0;
  double held_over_buoyancy = 0;  ///< that held force / rho g V (unit: 1)
  double side = 0;             ///< largest mean sideways speed |v_x|, |v_y| over the same window (unit: m/s)
  double wall_seconds = 0;     ///< (unit: s)
};

/// Runs `scene` (stokes_fall.yaml) at spacing dx.
FallCheck fallingBall(const std::string& scene, double dx, const std::vector<std::string>& sets = {},
                      const std::string& device = "");

/// A buoyant box placed flush on the floor (scenes/tests/rising_block.yaml): compile lifts it to a
/// gap of dx (a note says so), it rises and floats. Its draft against Archimedes' h rho_b / rho.
struct FloatCheck {
  int exit_code = 0;
  std::string message;
  double dx = 0;             ///< (unit: m)
  double height = 0;         ///< the box's height h (unit: m)
  double lift = 0;           ///< its start height minus the scene's (compile's gap) (unit: m)
  /// the water level (fluid volume at rest density plus the displaced m / rho, over the floor area)
  /// minus the box's underside, mean over the run's last 0.3 s (unit: m)
  double draft = 0;
  double expected = 0;       ///< h rho_b / rho (unit: m)
  double wall_seconds = 0;   ///< (unit: s)
};

/// Runs `scene` (rising_block.yaml) at spacing dx.
FloatCheck risingBlock(const std::string& scene, double dx, const std::vector<std::string>& sets = {},
                       const std::string& device = "");

/// A buoyant ball released mid-water rises, overshoots the surface and heaves about its float
/// position (scenes/tests/release_ball.yaml run longer): its mean height against Archimedes' draft,
/// and its damped heave's period against the floating sphere's heave natural period.
struct HeaveCheck {
  int exit_code = 0;
  std::string message;
  double dx = 0;               ///< (unit: m)
  double radius = 0;           ///< (unit: m)
  /// the water level: the fluid's volume at rest density plus the displaced volume m / rho, over
  /// the floor area (unit: m)
  double level = 0;
  double mean = 0;             ///< the ball's mean centre height over the run's last 0.2 s (unit: m)
  /// Archimedes: a ball of half the water's density floats half submerged, its centre at the level;
  /// (mean - level) (unit: m)
  double offset = 0;
  int crests = 0;              ///< local maxima of the centre height above `mean` after the release (unit: 1)
  double crest1 = 0, crest2 = 0;  ///< the first two crests' heights above `mean` (unit: m)
  double period = 0;           ///< crest-to-crest time of the first two crests (unit: s)
  double zeta = 0;             ///< damping ratio from the logarithmic decrement of the two crests (unit: 1)
  double period_undamped = 0;  ///< period sqrt(1 - zeta^2) (unit: s)
  /// 2 pi sqrt((m + a33) / (rho g pi R^2)), the heave added mass a33 of a floating hemisphere
  /// 0.38 .. 0.83 of its displaced mass rho V / 2 over all frequencies (Hulme 1982, J. Fluid Mech.
  /// 121, 443) (unit: s)
  double period_lo = 0, period_hi = 0;
  double wall_seconds = 0;     ///< (unit: s)
};

/// Runs `scene` (release_ball.yaml) at spacing dx, ball density 500 kg/m^3, to `duration` s (the
/// last 0.2 s give the mean; samples once per frame).
HeaveCheck floatingBallHeave(const std::string& scene, double dx, double duration,
                             const std::vector<std::string>& sets = {}, const std::string& device = "");

}  // namespace sph::app

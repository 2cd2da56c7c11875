// `sphaptics forces FORCES_CSV`: how smooth a body's fluid force is for a haptic device.
//
// The input is the per-step force log (forces.csv, written with `output.step_forces: true`). For
// one body over a time window, the drag is the fluid force against the body's motion,
//     D(t) = -F(t) . v(t) / |v(t)|,
// resampled onto a uniform grid (the step length changes when CFL control subdivides a frame).
// The report compares, relative to the mean drag:
//   - the raw signal: RMS fluctuation about its linear trend over the window (the trend is the
//     slow, physical change of the drag, e.g. a wake building up; what is left is noise), and the
//     RMS of its spectral content above the cut-off (one-sided DFT band power, Parseval);
//   - the felt signal, after the servo's environment-force filter (/work/shared/haptics.md: one
//     pole at 25 Hz): the same two figures.
// The filter is the exact discretisation of the RC low-pass for a sample-and-hold input,
//     y_n = y_n-1 + a (x_n - y_n-1),   a = 1 - exp(-2 pi fc dt),
// started at the window's mean (as if the servo had been running), so its start-up transient does
// not count as noise.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace sph::app {

/// A body's drag series: times (unit: s, increasing) and drag values (unit: N).
struct DragSeries {
  std::vector<double> t, drag;
};

/// Reads forces.csv (io::StepForcesCsvWriter) and returns the drag series of `body` (empty: the
/// first body in the file) for t in [from, to]; rows where the body is at rest are skipped. Throws
/// InputError on a missing file, a bad row or an unknown body. With `torque`, the series is the
/// resisting torque -T . w / |w| (unit: N m) of a turning body instead (a stirring paddle).
DragSeries readDragSeries(const std::string& path, const std::string& body, double from, double to, bool torque = false);

/// One-pole low-pass (cut-off fc, unit: Hz) of a uniformly sampled signal (step dt, unit: s),
/// started at y0.
std::vector<double> onePoleLowPass(const std::vector<double>& x, double dt, double fc, double y0);

/// RMS of the part of x above fc (unit: Hz): one-sided DFT band power of x minus its mean
/// (Parseval: mean square = sum over the band of 2 |X_k|^2 / N^2, the Nyquist bin once).
double bandRms(const std::vector<double>& x, double dt, double fc);

struct SmoothnessReport {
  std::size_t samples = 0;     ///< uniform samples in the window
  double dt = 0;               ///< their spacing: the median step of the log (unit: s)
  double duration = 0;         ///< window length (unit: s)
  double mean = 0;             ///< mean drag (unit: N)
  double rms = 0;              ///< raw: RMS about the linear trend (unit: N)
  double rms_above = 0;        ///< raw: RMS of the content above the cut-off (unit: N)
  double felt_rms = 0;         ///< after the one-pole low-pass: RMS about its linear trend (unit: N)
  double felt_rms_above = 0;   ///< after the low-pass: RMS above the cut-off (unit: N)
  double frame_rms = 0;        ///< the drag sampled at `frame_rate` only (as bodies.csv would): RMS about the trend (unit: N)
};

/// The smoothness figures of a drag series for a servo low-pass at `cutoff` (unit: Hz);
/// `frame_rate` (unit: 1/s) picks the per-frame samples for frame_rms (0: skip).
SmoothnessReport analyseDrag(const DragSeries& series, double cutoff, double frame_rate);

struct ForcesOptions {
  std::string file;                ///< forces.csv
  std::string body;                ///< body name; empty = the first in the file
  double from = 0;                 ///< window start (unit: s)
  double to = 1e30;                ///< window end (unit: s)
  double cutoff = 25;              ///< servo low-pass cut-off (unit: Hz)
  double frame_rate = 0;           ///< also report the noise of per-frame samples at this rate (unit: 1/s)
  bool torque = false;             ///< analyse the resisting torque about the angular velocity instead of the drag
};

/// Prints the report; returns 0, or 2 on unreadable input.
int forcesCommand(const ForcesOptions& opt, std::ostream& out, std::ostream& err);

}  // namespace sph::app

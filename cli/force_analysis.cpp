#include "cli/force_analysis.h"

#include "core/errors.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

namespace sph::app {

namespace {

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream s(line);
  for (std::string cell; std::getline(s, cell, ',');) cells.push_back(cell);
  return cells;
}

/// Least-squares line a + b t through (t, x).
void linearFit(const std::vector<double>& t, const std::vector<double>& x, double& a, double& b) {
  const double n = static_cast<double>(t.size());
  double st = 0, sx = 0, stt = 0, stx = 0;
  for (std::size_t i = 0; i < t.size(); ++i) st += t[i], sx += x[i], stt += t[i] * t[i], stx += t[i] * x[i];
  const double den = n * stt - st * st;
  b = den != 0.0 ? (n * stx - st * sx) / den : 0.0;
  a = (sx - b * st) / n;
}

double rmsOf(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v * v;
  return x.empty() ? 0.0 : std::sqrt(s / static_cast<double>(x.size()));
}

/// x minus its least-squares line over t.
std::vector<double> detrended(const std::vector<double>& t, const std::vector<double>& x) {
  double a = 0, b = 0;
  linearFit(t, x, a, b);
  std::vector<double> r(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) r[i] = x[i] - (a + b * t[i]);
  return r;
}

}  // namespace

DragSeries readDragSeries(const std::string& path, const std::string& body, double from, double to, bool torque) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, 0, "cannot open the force log");
  std::map<std::string, std::size_t> col;
  DragSeries out;
  std::string chosen = body;
  bool seen_body = false;
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> cells = splitCsv(line);
    if (col.empty()) {  // the header row
      for (std::size_t c = 0; c < cells.size(); ++c) col[cells[c]] = c;
      for (const char* need : {"time", "body", "vx", "vy", "vz", "wx", "wy", "wz", "fluid_fx", "fluid_fy", "fluid_fz",
                               "fluid_tx", "fluid_ty", "fluid_tz"})
        if (!col.count(need)) throw InputError(path, line_no, 1, std::string("no column '") + need + "' (not a forces.csv?)");
      continue;
    }
    if (cells.size() < col.size()) throw InputError(path, line_no, 1, "short row");
    const std::string& name = cells[col["body"]];
    if (chosen.empty()) chosen = name;
    if (name != chosen) continue;
    seen_body = true;
    double v[7];
    const char* keys[7] = {"time", "vx", "vy", "vz", "fluid_fx", "fluid_fy", "fluid_fz"};
    if (torque) keys[1] = "wx", keys[2] = "wy", keys[3] = "wz", keys[4] = "fluid_tx", keys[5] = "fluid_ty", keys[6] = "fluid_tz";
    for (int k = 0; k < 7; ++k) {
      char* end = nullptr;
      const std::string& text = cells[col[keys[k]]];
      v[k] = std::strtod(text.c_str(), &end);
      if (end == text.c_str()) throw InputError(path, line_no, 1, std::string("'") + keys[k] + "' is not a number");
    }
    const double t = v[0], speed = std::sqrt(v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
    if (t < from || t > to || speed <= 0.0) continue;
    out.t.push_back(t);
    out.drag.push_back(-(v[4] * v[1] + v[5] * v[2] + v[6] * v[3]) / speed);
  }
  if (col.empty()) throw InputError(path, 0, 0, "no header row (not a forces.csv?)");
  if (!seen_body) throw InputError(path, 0, 0, "no rows for body '" + chosen + "'");
  return out;
}

std::vector<double> onePoleLowPass(const std::vector<double>& x, double dt, double fc, double y0) {
  const double a = 1.0 - std::exp(-2.0 * M_PI * fc * dt);
  std::vector<double> y(x.size());
  double state = y0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    state += a * (x[i] - state);
    y[i] = state;
  }
  return y;
}

double bandRms(const std::vector<double>& x, double dt, double fc) {
  const std::size_t n = x.size();
  if (n < 2) return 0.0;
  double mean = 0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(n);
  // First bin strictly above fc: f_k = k / (n dt).
  const std::size_t k0 = static_cast<std::size_t>(std::floor(fc * static_cast<double>(n) * dt)) + 1;
  double power = 0;  // mean square in the band
  for (std::size_t k = std::max<std::size_t>(k0, 1); 2 * k <= n; ++k) {
    // X_k = sum x_n exp(-2 pi i k n / N), with the rotation applied by recurrence.
    const double angle = -2.0 * M_PI * static_cast<double>(k) / static_cast<double>(n);
    const double c = std::cos(angle), s = std::sin(angle);
    double re = 0, im = 0, wr = 1, wi = 0;
    for (std::size_t j = 0; j < n; ++j) {
      const double v = x[j] - mean;
      re += v * wr;
      im += v * wi;
      const double t = wr * c - wi * s;
      wi = wr * s + wi * c;
      wr = t;
    }
    const double weight = 2 * k == n ? 1.0 : 2.0;  // the Nyquist bin has no mirror
    power += weight * (re * re + im * im) / (static_cast<double>(n) * static_cast<double>(n));
  }
  return std::sqrt(power);
}

SmoothnessReport analyseDrag(const DragSeries& series, double cutoff, double frame_rate) {
  SmoothnessReport r;
  const std::size_t m = series.t.size();
  if (m < 4) return r;
  // Uniform resampling at the median step (linear interpolation).
  std::vector<double> steps;
  for (std::size_t i = 1; i < m; ++i) steps.push_back(series.t[i] - series.t[i - 1]);
  std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
  const double dt = steps[steps.size() / 2];
  if (!(dt > 0)) return r;
  const double t0 = series.t.front(), t1 = series.t.back();
  const std::size_t n = static_cast<std::size_t>(std::floor((t1 - t0) / dt)) + 1;
  std::vector<double> t(n), x(n);
  std::size_t j = 0;
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = t0 + static_cast<double>(i) * dt;
    while (j + 2 < m && series.t[j + 1] <= t[i]) ++j;
    const double span = series.t[j + 1] - series.t[j];
    const double w = span > 0 ? std::clamp((t[i] - series.t[j]) / span, 0.0, 1.0) : 0.0;
    x[i] = (1 - w) * series.drag[j] + w * series.drag[j + 1];
  }
  r.samples = n;
  r.dt = dt;
  r.duration = t1 - t0;
  double sum = 0;
  for (double v : x) sum += v;
  r.mean = sum / static_cast<double>(n);

  const std::vector<double> noise = detrended(t, x);
  r.rms = rmsOf(noise);
  r.rms_above = bandRms(noise, dt, cutoff);

  // What the hand feels: the servo's one-pole filter, started on the trend.
  double a = 0, b = 0;
  linearFit(t, x, a, b);
  const std::vector<double> felt = onePoleLowPass(x, dt, cutoff, a + b * t0);
  const std::vector<double> felt_noise = detrended(t, felt);
  r.felt_rms = rmsOf(felt_noise);
  r.felt_rms_above = bandRms(felt_noise, dt, cutoff);

  // The same signal seen once per output frame (bodies.csv samples the frame's last step).
  if (frame_rate > 0) {
    std::vector<double> ft, fx;
    const double frame = 1.0 / frame_rate;
    for (double tf = std::ceil(t0 / frame) * frame; tf <= t1; tf += frame) {
      std::size_t k = 0;  // the last sample at or before tf
      while (k + 1 < m && series.t[k + 1] <= tf + 1e-12) ++k;
      ft.push_back(series.t[k]);
      fx.push_back(series.drag[k]);
    }
    if (ft.size() >= 3) r.frame_rms = rmsOf(detrended(ft, fx));
  }
  return r;
}

int forcesCommand(const ForcesOptions& opt, std::ostream& out, std::ostream& err) {
  DragSeries series;
  try {
    series = readDragSeries(opt.file, opt.body, opt.from, opt.to, opt.torque);
  } catch (const InputError& e) {
    for (const auto& issue : e.issues()) err << "error: " << issue.str() << "\n";
    return 2;
  }
  if (series.t.size() < 4) {
    err << "error: " << opt.file << ": fewer than 4 moving samples in the window\n";
    return 2;
  }
  const SmoothnessReport r = analyseDrag(series, opt.cutoff, opt.frame_rate);
  auto pct = [&](double v) { return r.mean != 0 ? 100.0 * v / std::abs(r.mean) : 0.0; };
  char buf[256];
  std::snprintf(buf, sizeof buf, "window %.4g s, %zu samples at dt = %.4g s (Nyquist %.0f Hz)\n", r.duration, r.samples, r.dt,
                0.5 / r.dt);
  out << buf;
  if (opt.torque) std::snprintf(buf, sizeof buf, "mean resisting torque %.6g N m (torque against the turn; N below reads N m)\n", r.mean);
  else std::snprintf(buf, sizeof buf, "mean drag %.6g N (force against the motion)\n", r.mean);
  out << buf;
  std::snprintf(buf, sizeof buf, "raw:              RMS fluctuation %.4g N (%.1f %%), above %.0f Hz %.4g N (%.1f %%)\n", r.rms,
                pct(r.rms), opt.cutoff, r.rms_above, pct(r.rms_above));
  out << buf;
  std::snprintf(buf, sizeof buf, "after %.0f Hz 1-pole: RMS fluctuation %.4g N (%.1f %%), above %.0f Hz %.4g N (%.1f %%)\n",
                opt.cutoff, r.felt_rms, pct(r.felt_rms), opt.cutoff, r.felt_rms_above, pct(r.felt_rms_above));
  out << buf;
  if (opt.frame_rate > 0) {
    std::snprintf(buf, sizeof buf, "per-frame samples at %.4g Hz: RMS fluctuation %.4g N (%.1f %%)\n", opt.frame_rate,
                  r.frame_rms, pct(r.frame_rms));
    out << buf;
  }
  return 0;
}

}  // namespace sph::app

#include "cli/compare.h"

#include "core/errors.h"
#include "core/mesh.h"
#include "core/mesh_distance.h"
#include "io/obj_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <vector>

namespace fs = std::filesystem;

namespace sph::app {

namespace {

// name -> path of every *.obj in a folder, or the single file itself.
std::map<std::string, fs::path> objFiles(const fs::path& p) {
  std::map<std::string, fs::path> files;
  if (fs::is_directory(p)) {
    for (const auto& e : fs::directory_iterator(p))
      if (e.is_regular_file() && e.path().extension() == ".obj") files[e.path().filename().string()] = e.path();
    if (files.empty()) throw InputError(p.string(), 0, 0, "folder holds no .obj files");
  } else if (fs::exists(p)) {
    files[p.filename().string()] = p;
  } else {
    throw InputError(p.string(), 0, 0, "no such file or folder");
  }
  return files;
}

// "# particle_spacing: 0.01 m" in the comment block at the top of an OBJ written by sphaptics.
double spacingFromHeader(const fs::path& p) {
  std::ifstream f(p);
  std::string line;
  const std::string key = "particle_spacing:";
  while (std::getline(f, line) && !line.empty() && line[0] == '#') {
    const auto at = line.find(key);
    if (at == std::string::npos) continue;
    std::istringstream in(line.substr(at + key.size()));
    double v = 0;
    if (in >> v && v > 0) return v;
  }
  return 0;
}

struct FrameResult {
  std::string name;
  std::size_t verts_a = 0, verts_b = 0;
  double hausdorff = 0;  // m
  double dvolume = 0;    // m (|dV| / mean area)
  double darea = 0;      // fraction
  bool ok = false;
  std::string note;
};

}  // namespace

int compareCommand(const CompareOptions& opt, std::ostream& out, std::ostream& err) {
  std::map<std::string, fs::path> fa, fb;
  try {
    fa = objFiles(opt.a);
    fb = objFiles(opt.b);
  } catch (const InputError& e) {
    for (const auto& i : e.issues()) err << "error: " << i.str() << "\n";
    return kExitBadInput;
  }
  // Two single files are one frame whatever their names; folders are matched by file name.
  const bool single = fa.size() == 1 && fb.size() == 1 && !fs::is_directory(opt.a) && !fs::is_directory(opt.b);
  std::vector<std::pair<std::string, std::pair<fs::path, fs::path>>> frames;
  std::vector<std::string> only_a, only_b;
  if (single) {
    frames.push_back({fa.begin()->first, {fa.begin()->second, fb.begin()->second}});
  } else {
    for (const auto& [name, path] : fa) {
      auto it = fb.find(name);
      if (it == fb.end()) only_a.push_back(name);
      else frames.push_back({name, {path, it->second}});
    }
    for (const auto& [name, path] : fb)
      if (!fa.count(name)) only_b.push_back(name);
  }

  double dx = opt.spacing;
  if (!(dx > 0) && !frames.empty()) dx = spacingFromHeader(frames.front().second.first);
  if (!(dx > 0) && !frames.empty()) dx = spacingFromHeader(frames.front().second.second);
  if (!(dx > 0)) {
    err << "error: no 'particle_spacing:' line in the OBJ header of " << opt.a
        << "; pass --spacing (unit: m) to set the unit of the tolerances\n";
    return kExitBadInput;
  }

  std::vector<FrameResult> results;
  for (const auto& [name, paths] : frames) {
    FrameResult r;
    r.name = name;
    TriMesh a, b;
    try {
      a = io::readObj(paths.first.string(), true);
      b = io::readObj(paths.second.string(), true);
    } catch (const InputError& e) {
      for (const auto& i : e.issues()) err << "error: " << i.str() << "\n";
      return kExitBadInput;
    }
    r.verts_a = a.numVertices();
    r.verts_b = b.numVertices();
    if (a.triangles.empty() && b.triangles.empty()) {
      r.ok = true;
      r.note = "both empty";
      results.push_back(r);
      continue;
    }
    r.hausdorff = hausdorff(a, b);
    const double area_a = meshArea(a), area_b = meshArea(b);
    const double mean_area = 0.5 * (area_a + area_b);
    r.dvolume = mean_area > 0 ? std::abs(meshVolume(a) - meshVolume(b)) / mean_area : 0.0;
    r.darea = std::max(area_a, area_b) > 0 ? std::abs(area_a - area_b) / std::max(area_a, area_b) : 0.0;
    r.ok = std::isfinite(r.hausdorff) && r.hausdorff <= opt.hausdorff * dx && r.dvolume <= opt.volume * dx &&
           r.darea <= opt.area;
    if (!std::isfinite(r.hausdorff)) r.note = "one side empty";
    results.push_back(r);
  }

  std::size_t failed = 0;
  double worst_h = 0;
  for (const auto& r : results) {
    failed += !r.ok;
    if (std::isfinite(r.hausdorff)) worst_h = std::max(worst_h, r.hausdorff);
  }
  if (!opt.quiet) {
    char line[256];
    std::snprintf(line, sizeof line, "%-32s %9s %9s %14s %12s %8s  %s\n", "frame", "verts A", "verts B",
                  "hausdorff[dx]", "dV/area[dx]", "dA[%]", "result");
    out << line;
    for (const auto& r : results) {
      std::snprintf(line, sizeof line, "%-32s %9zu %9zu %14.4f %12.4f %8.3f  %s%s%s\n", r.name.c_str(), r.verts_a,
                    r.verts_b, r.hausdorff / dx, r.dvolume / dx, 100.0 * r.darea, r.ok ? "ok" : "FAIL",
                    r.note.empty() ? "" : " ", r.note.c_str());
      out << line;
    }
    for (const auto& n : only_a) out << n << ": only in " << opt.a << "  FAIL\n";
    for (const auto& n : only_b) out << n << ": only in " << opt.b << "  FAIL\n";
  }
  const bool pass = failed == 0 && only_a.empty() && only_b.empty();
  char summary[256];
  std::snprintf(summary, sizeof summary,
                "compare: %zu frames, %zu outside tolerance, %zu unmatched; worst hausdorff %.4f dx "
                "(tolerances: hausdorff %.3g dx, volume %.3g dx, area %.3g %%; dx = %.6g m): %s\n",
                results.size(), failed, only_a.size() + only_b.size(), worst_h / dx, opt.hausdorff, opt.volume,
                100.0 * opt.area, dx, pass ? "PASS" : "FAIL");
  out << summary;
  return pass ? 0 : 1;
}

}  // namespace sph::app

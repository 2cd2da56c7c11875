#include "io/run_folder.h"

#include "core/errors.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

namespace sph::io {

namespace fs = std::filesystem;

namespace {

/// A 3-vector from a JSON array of three numbers, or `fallback` when it is not one.
Eigen::Vector3f vec3(const YAML::Node& n, const Eigen::Vector3f& fallback) {
  if (!n || !n.IsSequence() || n.size() != 3) return fallback;
  try {
    return {n[0].as<float>(), n[1].as<float>(), n[2].as<float>()};
  } catch (const YAML::Exception&) {
    return fallback;
  }
}

}  // namespace

RunFolderInfo readRunFolderInfo(const std::string& dir) {
  RunFolderInfo info;
  const fs::path path = fs::path(dir) / "run.json";
  if (!fs::exists(path)) return info;
  // JSON is YAML 1.2 flow style: yaml-cpp reads it and reports positions.
  YAML::Node root;
  try {
    root = YAML::LoadFile(path.string());
  } catch (const YAML::ParserException& e) {
    throw InputError(path.string(), e.mark.line + 1, e.mark.column + 1, "run.json is not valid JSON: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw InputError(path.string(), 0, 0, std::string("cannot read run.json: ") + e.what());
  }
  if (!root.IsMap()) throw InputError(path.string(), 1, 1, "run.json is not a JSON object");
  try {
    if (root["status"]) info.status = root["status"].as<std::string>();
    const YAML::Node scene = root["scene"];
    if (!scene || !scene.IsMap()) return info;
    // Domain box, spacing and frame rate.
    if (const YAML::Node d = scene["domain"]; d && d.IsMap() && d["min"] && d["max"]) {
      info.domain_min = vec3(d["min"], info.domain_min);
      info.domain_max = vec3(d["max"], info.domain_max);
      info.has_domain = (info.domain_max.array() > info.domain_min.array()).all();
    }
    if (const YAML::Node f = scene["fluid"]; f && f.IsMap()) {
      if (f["particle_spacing"]) info.particle_spacing = f["particle_spacing"].as<double>();
      if (const YAML::Node phases = f["phases"]; phases && phases.IsSequence())
        for (const YAML::Node& p : phases)
          info.phases.emplace_back(p["name"] ? p["name"].as<std::string>() : std::string(),
                                   vec3(p["colour"], Eigen::Vector3f(0.2f, 0.4f, 0.9f)));
    }
    if (const YAML::Node s = scene["simulation"]; s && s.IsMap() && s["frame_rate"])
      info.frame_rate = s["frame_rate"].as<double>();
    // Bodies and their colours.
    if (const YAML::Node bodies = scene["rigid_bodies"]; bodies && bodies.IsSequence())
      for (const YAML::Node& b : bodies)
        info.bodies.emplace_back(b["name"] ? b["name"].as<std::string>() : std::string(),
                                 vec3(b["colour"], Eigen::Vector3f(0.7f, 0.7f, 0.7f)));
    // Cloths and their colours.
    if (const YAML::Node cloths = scene["cloth"]; cloths && cloths.IsSequence())
      for (const YAML::Node& c : cloths)
        info.cloths.emplace_back(c["name"] ? c["name"].as<std::string>() : std::string(),
                                 vec3(c["colour"], Eigen::Vector3f(0.8f, 0.3f, 0.3f)));
    // Soft bodies and their colours.
    if (const YAML::Node softs = scene["soft_bodies"]; softs && softs.IsSequence())
      for (const YAML::Node& b : softs)
        info.soft_bodies.emplace_back(b["name"] ? b["name"].as<std::string>() : std::string(),
                                      vec3(b["colour"], Eigen::Vector3f(0.85f, 0.55f, 0.5f)));
  } catch (const YAML::Exception& e) {
    throw InputError(path.string(), e.mark.line + 1, e.mark.column + 1, std::string("unexpected run.json content: ") + e.msg);
  }
  return info;
}

std::string particlesFile(const std::string& dir) {
  const fs::path final_file = fs::path(dir) / "particles.h5part";
  if (fs::exists(final_file)) return final_file.string();
  const fs::path partial = fs::path(dir) / "particles.h5part.partial";
  if (fs::exists(partial)) return partial.string();
  return "";
}

std::vector<ObjSequence> scanObjSequences(const std::string& dir) {
  std::map<std::string, ObjSequence> seqs;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    // <prefix>_NNNN.obj with prefix fluid_*, body_*, cloth_* or soft_*, NNNN four or more digits.
    const std::string name = entry.path().filename().string();
    if (name.size() < 10 || name.compare(name.size() - 4, 4, ".obj") != 0) continue;
    const bool cloth = name.rfind("cloth_", 0) == 0;
    const bool soft = name.rfind("soft_", 0) == 0;
    const bool body = cloth || soft || name.rfind("body_", 0) == 0;
    if (!body && name.rfind("fluid_", 0) != 0) continue;
    const std::string stem = name.substr(0, name.size() - 4);
    const std::size_t us = stem.rfind('_');
    if (us == std::string::npos || us + 1 >= stem.size()) continue;
    const std::string digits = stem.substr(us + 1);
    if (!std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
      continue;
    ObjSequence& s = seqs[stem.substr(0, us)];
    s.name = stem.substr(0, us);
    s.body = body;
    s.cloth = cloth;
    s.soft = soft;
    s.frames[std::stoi(digits)] = entry.path().string();
  }
  std::vector<ObjSequence> out;
  for (auto& [name, s] : seqs) out.push_back(std::move(s));
  return out;
}

}  // namespace sph::io

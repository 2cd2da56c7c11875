// The schema table: the single source of truth for every scene key (type, default, unit, allowed
// values, one line of doc). The loader, `sphaptics schema` and `sphaptics validate` all use it.
#pragma once

#include <string>

namespace sph::io {

/// Human-readable listing of every key, one per line: path, type, default, unit, allowed values, doc.
std::string schemaText();

}  // namespace sph::io

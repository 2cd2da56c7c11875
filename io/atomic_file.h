// Writing a file so that a reader never sees it half written: a temporary beside it, then rename.
#pragma once

#include <string>

namespace sph::io {

/// Writes `content` to `path` atomically. Throws std::runtime_error naming the file and the OS
/// reason (strerror) on failure; the temporary file is removed again.
void writeFileAtomic(const std::string& path, const std::string& content);

}  // namespace sph::io

#include "io/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace sph::io {

void writeFileAtomic(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".tmp";
  // Any failure names the OS reason (strerror) and removes the temporary file again.
  auto fail = [&](const std::string& what, int err) {
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot " + what + ": " + std::strerror(err));
  };
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail("write " + tmp, errno);
  // Write all of it (write() may write less than asked), retrying on EINTR.
  std::size_t done = 0;
  while (done < content.size()) {
    const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      fail("write " + tmp, err);
    }
    done += static_cast<std::size_t>(n);
  }
  // close() reports delayed write errors (NFS, quota).
  if (::close(fd) != 0) fail("write " + tmp, errno);
  if (std::rename(tmp.c_str(), path.c_str()) != 0) fail("rename " + tmp + " to " + path, errno);
}

}  // namespace sph::io

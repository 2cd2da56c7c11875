// QuietHdf5: silences HDF5's printing of its error stack to stderr while in scope, so that
// failures become exceptions whose message names the file (shared by the H5Part reader and writer;
// include it only from io/ sources, which see HDF5's headers).
#pragma once

#include <hdf5.h>

namespace sph::io {

class QuietHdf5 {
 public:
  QuietHdf5() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietHdf5() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  QuietHdf5(const QuietHdf5&) = delete;
  QuietHdf5& operator=(const QuietHdf5&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

}  // namespace sph::io

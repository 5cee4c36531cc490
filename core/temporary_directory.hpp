#pragma once
// A fresh private temporary directory (mkdtemp under the system's temporary folder), removed
// with everything in it when the object goes out of scope: scratch files twill creates itself
// (twill inspect's plot data, twill discover's held-out parameter files).
#include <string>

namespace twill {

class TemporaryDirectory {
 public:
  /// Throws std::runtime_error when the directory cannot be created.
  explicit TemporaryDirectory(const std::string& prefix);
  ~TemporaryDirectory();
  TemporaryDirectory(const TemporaryDirectory&) = delete;
  TemporaryDirectory& operator=(const TemporaryDirectory&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace twill

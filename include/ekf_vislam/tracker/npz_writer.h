// Writes numpy .npz archives (a zip of .npy files, stored uncompressed) of float64 and int64
// arrays, readable by numpy.load. No ROS, no zlib.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ekf_vislam {

class NpzWriter {
 public:
  /// A C-ordered float64 array; shape {} is a scalar. data.size() must be the shape's product.
  void addDoubles(const std::string& name, const std::vector<size_t>& shape,
                  const std::vector<double>& data);
  /// A C-ordered int64 array.
  void addInts(const std::string& name, const std::vector<size_t>& shape,
               const std::vector<int64_t>& data);
  /// Writes `path.tmp` and renames it to `path`; false and *error on failure.
  bool write(const std::string& path, std::string* error) const;

 private:
  struct Member {
    std::string name;   ///< file name in the archive (name + ".npy")
    std::string bytes;  ///< the .npy file
  };
  std::vector<Member> members_;
};

/// CRC-32 (zip polynomial) of a byte string.
uint32_t crc32(const std::string& bytes);

}  // namespace ekf_vislam

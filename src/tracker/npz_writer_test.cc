#include "ekf_vislam/tracker/npz_writer.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>

namespace ekf_vislam {
namespace {

TEST(NpzWriter, Crc32OfTheStandardCheckString) {
  EXPECT_EQ(crc32("123456789"), 0xCBF43926u);
  EXPECT_EQ(crc32(""), 0u);
}

TEST(NpzWriter, WritesAZipOfNpyFiles) {
  NpzWriter npz;
  npz.addDoubles("features", {4, 2, 3}, std::vector<double>(24, -1.0));
  npz.addDoubles("b", {}, {0.54});
  npz.addInts("image_size", {2}, {1241, 376});
  EXPECT_THROW(npz.addDoubles("bad", {2, 2}, {1.0}), std::invalid_argument);
  const std::string path = ::testing::TempDir() + "/npz_writer_test.npz";
  std::string error;
  ASSERT_TRUE(npz.write(path, &error)) << error;
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string bytes = buffer.str();
  std::remove(path.c_str());
  EXPECT_EQ(bytes.substr(0, 4), std::string("PK\x03\x04", 4));
  EXPECT_NE(bytes.find("features.npy"), std::string::npos);
  EXPECT_NE(bytes.find("'shape': (4, 2, 3)"), std::string::npos);
  EXPECT_NE(bytes.find("'shape': ()"), std::string::npos);
  EXPECT_NE(bytes.find("'descr': '<i8', 'fortran_order': False, 'shape': (2,)"), std::string::npos);
  // Each .npy header (magic + length + dict) is a multiple of 64 bytes.
  const size_t npy = bytes.find("\x93NUMPY");
  ASSERT_NE(npy, std::string::npos);
  const size_t header_length =
      static_cast<unsigned char>(bytes[npy + 8]) + 256 * static_cast<unsigned char>(bytes[npy + 9]);
  EXPECT_EQ((10 + header_length) % 64, 0u);
  EXPECT_EQ(bytes.substr(bytes.size() - 22, 4), std::string("PK\x05\x06", 4));
}

}  // namespace
}  // namespace ekf_vislam

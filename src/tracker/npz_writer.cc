#include "ekf_vislam/tracker/npz_writer.h"

#include <array>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace ekf_vislam {

namespace {

std::string shapeText(const std::vector<size_t>& shape) {
  if (shape.size() == 1) return "(" + std::to_string(shape[0]) + ",)";
  std::string text = "(";
  for (size_t i = 0; i < shape.size(); ++i) text += (i ? ", " : "") + std::to_string(shape[i]);
  return text + ")";
}

size_t count(const std::vector<size_t>& shape) {
  size_t n = 1;
  for (size_t s : shape) n *= s;
  return n;
}

// .npy version 1.0: magic, header length, a Python dict padded with spaces to 64 bytes, data.
std::string npyFile(const char* descr, const std::vector<size_t>& shape, const void* data,
                    size_t data_bytes) {
  std::string header = std::string("{'descr': '") + descr +
                       "', 'fortran_order': False, 'shape': " + shapeText(shape) + ", }";
  const size_t prefix = 10;
  const size_t total = ((prefix + header.size() + 1 + 63) / 64) * 64;
  header.append(total - prefix - header.size() - 1, ' ');
  header += '\n';
  std::string bytes("\x93NUMPY\x01\x00", 8);
  bytes += static_cast<char>(header.size() & 0xff);
  bytes += static_cast<char>((header.size() >> 8) & 0xff);
  bytes += header;
  bytes.append(static_cast<const char*>(data), data_bytes);
  return bytes;
}

void put16(std::string* out, uint32_t v) {
  out->push_back(static_cast<char>(v & 0xff));
  out->push_back(static_cast<char>((v >> 8) & 0xff));
}
void put32(std::string* out, uint32_t v) {
  put16(out, v & 0xffff);
  put16(out, v >> 16);
}

}  // namespace

uint32_t crc32(const std::string& bytes) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  uint32_t crc = 0xFFFFFFFFu;
  for (unsigned char byte : bytes) crc = table[(crc ^ byte) & 0xff] ^ (crc >> 8);
  return crc ^ 0xFFFFFFFFu;
}

void NpzWriter::addDoubles(const std::string& name, const std::vector<size_t>& shape,
                           const std::vector<double>& data) {
  if (data.size() != count(shape)) throw std::invalid_argument("npz " + name + ": size != shape");
  members_.push_back({name + ".npy", npyFile("<f8", shape, data.data(), data.size() * 8)});
}

void NpzWriter::addInts(const std::string& name, const std::vector<size_t>& shape,
                        const std::vector<int64_t>& data) {
  if (data.size() != count(shape)) throw std::invalid_argument("npz " + name + ": size != shape");
  members_.push_back({name + ".npy", npyFile("<i8", shape, data.data(), data.size() * 8)});
}

bool NpzWriter::write(const std::string& path, std::string* error) const {
  std::string archive, directory;
  for (const Member& m : members_) {
    if (m.bytes.size() >= 0xFFFFFFFFu) {
      *error = path + ": array " + m.name + " too large for a zip without zip64";
      return false;
    }
    const uint32_t crc = crc32(m.bytes);
    const uint32_t offset = static_cast<uint32_t>(archive.size());
    const auto size = static_cast<uint32_t>(m.bytes.size());
    // Local file header: stored (method 0), no time stamp.
    put32(&archive, 0x04034b50);
    put16(&archive, 20);
    put16(&archive, 0);
    put16(&archive, 0);
    put16(&archive, 0);
    put16(&archive, 0x21);  // 1980-01-01
    put32(&archive, crc);
    put32(&archive, size);
    put32(&archive, size);
    put16(&archive, static_cast<uint32_t>(m.name.size()));
    put16(&archive, 0);
    archive += m.name;
    archive += m.bytes;
    // Central directory entry.
    put32(&directory, 0x02014b50);
    put16(&directory, 20);
    put16(&directory, 20);
    put16(&directory, 0);
    put16(&directory, 0);
    put16(&directory, 0);
    put16(&directory, 0x21);
    put32(&directory, crc);
    put32(&directory, size);
    put32(&directory, size);
    put16(&directory, static_cast<uint32_t>(m.name.size()));
    put16(&directory, 0);
    put16(&directory, 0);
    put16(&directory, 0);
    put16(&directory, 0);
    put32(&directory, 0);
    put32(&directory, offset);
    directory += m.name;
  }
  const auto directory_offset = static_cast<uint32_t>(archive.size());
  archive += directory;
  put32(&archive, 0x06054b50);
  put16(&archive, 0);
  put16(&archive, 0);
  put16(&archive, static_cast<uint32_t>(members_.size()));
  put16(&archive, static_cast<uint32_t>(members_.size()));
  put32(&archive, static_cast<uint32_t>(directory.size()));
  put32(&archive, directory_offset);
  put16(&archive, 0);

  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(archive.data(), static_cast<std::streamsize>(archive.size()));
    if (!out) {
      *error = temporary + ": cannot write";
      return false;
    }
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    *error = path + ": cannot rename " + temporary + " to it";
    std::remove(temporary.c_str());
    return false;
  }
  return true;
}

}  // namespace ekf_vislam

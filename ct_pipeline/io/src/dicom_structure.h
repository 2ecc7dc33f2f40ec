// The structure of a DICOM file as Sawyer checks it before GDCM may read it (dicom_structure.cpp),
// and the small pieces of file access the DICOM reader's files share. Internal.
#pragma once

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gdcmTag.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace sawyer::ct::detail {

// An open file descriptor that closes itself.
class Fd {
 public:
  explicit Fd(const std::filesystem::path& p) : fd_(::open(p.c_str(), O_RDONLY | O_CLOEXEC)) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  bool ok() const { return fd_ >= 0; }
  // Reads up to n bytes at offset; returns the count read (short at end of file), -1 on error.
  int64_t pread_all(void* dst, size_t n, int64_t offset) const {
    size_t done = 0;
    auto* p = static_cast<char*>(dst);
    while (done < n) {
      const ssize_t r = ::pread(fd_, p + done, n - done, static_cast<off_t>(offset + done));
      if (r < 0) {
        if (errno == EINTR) continue;
        return -1;
      }
      if (r == 0) break;
      done += static_cast<size_t>(r);
    }
    return static_cast<int64_t>(done);
  }
  int64_t size() const {
    struct stat st {};
    return ::fstat(fd_, &st) == 0 ? static_cast<int64_t>(st.st_size) : -1;
  }

 private:
  int fd_;
};

inline uint32_t le32(const unsigned char* p) {
  return p[0] | (p[1] << 8) | (p[2] << 16) | (static_cast<uint32_t>(p[3]) << 24);
}
inline uint32_t be32(const unsigned char* p) {
  return (static_cast<uint32_t>(p[0]) << 24) | (p[1] << 16) | (p[2] << 8) | p[3];
}
inline bool is_vr_letter(unsigned char c) { return c >= 'A' && c <= 'Z'; }

inline const gdcm::Tag kPixelDataTag(0x7fe0, 0x0010);

// How a data set is encoded, as its transfer syntax says.
enum class Encoding { kImplicitLittle, kExplicitLittle, kExplicitBig };

// What the walk learns about a file.
struct Structure {
  bool plain_message = false;   // the error is not corruption (unsupported syntax, truncation)
  std::string transfer_syntax;  // as in the meta header ("" for a bare data set)
  Encoding encoding = Encoding::kExplicitLittle;
  bool encapsulated_syntax = false;
  bool has_pixel_data = false;
  bool pixel_encapsulated = false;  // undefined length: fragments
  int64_t pixel_offset = 0;         // first byte of the value
  uint32_t pixel_length = 0;        // defined length (native)
  int pixel_fragments = 0;          // items after the offset table
};

// Walks the file that `fd` has open (`size` bytes) element by element and fills `out`: the
// checks are those of StructureWalker (dicom_structure.cpp). Empty string: fine; else what is
// wrong, for "corrupt DICOM: <what>" (or as it is when out.plain_message is set).
std::string check_structure(const Fd& fd, int64_t size, Structure& out);

}  // namespace sawyer::ct::detail

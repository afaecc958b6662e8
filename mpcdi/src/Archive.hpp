#pragma once
// A zip archive read whole entry by entry (libzip; PRIVATE to tellus::mpcdi), or an unpacked
// one: an mpcdi.xml given itself (exporters such as Christie's Mystique write FILE.mpcdi.xml),
// its entries the files beside it.

#include <expected>
#include <filesystem>
#include <memory>
#include <string>

namespace tellus::mpcdi::detail {

class Archive {
public:
  /** Opens FILE: a zip, or an XML document (its first byte after blanks '<'), which is then the
   * entry mpcdi.xml and the other entries files in its folder. Refused with "FILE: not a zip
   * archive" and the like. */
  static std::expected<Archive, std::string> open(const std::filesystem::path& file);
  Archive(Archive&&) noexcept;
  Archive& operator=(Archive&&) noexcept;
  ~Archive();
  /** The entry NAME's bytes; "no NAME in the archive" when it is missing (no file prefix). Entries
   * over maxBytes (uncompressed) are refused before they are inflated. */
  std::expected<std::string, std::string> read(const std::string& name,
                                               std::size_t maxBytes = std::size_t{1} << 30) const;
  const std::string& file() const noexcept { return file_; }

private:
  struct Impl;
  Archive(std::unique_ptr<Impl> impl, std::string file);
  std::unique_ptr<Impl> impl_;
  std::string file_;
};

} // namespace tellus::mpcdi::detail

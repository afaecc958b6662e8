#include "Archive.hpp"

#include <fstream>
#include <iterator>
#include <zip.h>

namespace tellus::mpcdi::detail {
namespace {

/** The file's bytes; why not when it cannot be read or is larger than maxBytes. */
std::expected<std::string, std::string> slurp(const std::filesystem::path& file,
                                              std::size_t maxBytes) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(file, ec);
  if (ec) return std::unexpected(std::string("cannot be read"));
  if (size > maxBytes) return std::unexpected("larger than " + std::to_string(maxBytes) + " bytes");
  std::ifstream in(file, std::ios::binary);
  std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (!in.good() && !in.eof()) return std::unexpected(std::string("cannot be read"));
  return bytes;
}

/** Whether FILE begins, after blanks, with '<' (an XML document, not a zip's "PK"). */
bool looksLikeXml(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  char c = 0;
  while (in.get(c))
    if (c != ' ' && c != '\t' && c != '\r' && c != '\n') return c == '<' || c == '\xef'; // BOM
  return false;
}

} // namespace

struct Archive::Impl {
  zip_t* zip = nullptr;
  std::filesystem::path folder; ///< unpacked: where the entries are
  std::string xml;              ///< unpacked: mpcdi.xml's bytes
  ~Impl() {
    if (zip != nullptr) zip_discard(zip);
  }
};

Archive::Archive(std::unique_ptr<Impl> impl, std::string file)
    : impl_(std::move(impl)), file_(std::move(file)) {}
Archive::Archive(Archive&&) noexcept = default;
Archive& Archive::operator=(Archive&&) noexcept = default;
Archive::~Archive() = default;

std::expected<Archive, std::string> Archive::open(const std::filesystem::path& file) {
  if (looksLikeXml(file)) { // an unpacked MPCDI: this file is its mpcdi.xml
    auto xml = slurp(file, std::size_t{64} << 20);
    if (!xml) return std::unexpected(file.string() + ": " + xml.error());
    auto impl = std::make_unique<Impl>();
    impl->folder = file.parent_path();
    impl->xml = std::move(*xml);
    return Archive(std::move(impl), file.string());
  }
  int code = 0;
  zip_t* z = zip_open(file.c_str(), ZIP_RDONLY | ZIP_CHECKCONS, &code);
  if (z == nullptr) {
    std::string what;
    switch (code) {
    case ZIP_ER_NOENT:
    case ZIP_ER_OPEN:
      what = "cannot be read";
      break;
    case ZIP_ER_NOZIP:
      what = "not a zip archive (an .mpcdi file is a zip of mpcdi.xml and its files)";
      break;
    case ZIP_ER_INCONS:
      what = "a damaged zip archive";
      break;
    default: {
      zip_error_t e;
      zip_error_init_with_code(&e, code);
      what = std::string("not a readable zip archive: ") + zip_error_strerror(&e);
      zip_error_fini(&e);
    }
    }
    return std::unexpected(file.string() + ": " + what);
  }
  auto impl = std::make_unique<Impl>();
  impl->zip = z;
  return Archive(std::move(impl), file.string());
}

std::expected<std::string, std::string> Archive::read(const std::string& name,
                                                      std::size_t maxBytes) const {
  if (impl_->zip == nullptr) { // unpacked: mpcdi.xml, then files in its folder, never outside
    if (name == "mpcdi.xml") return impl_->xml;
    const std::filesystem::path rel(name);
    if (name.empty() || rel.is_absolute() || rel.has_root_name())
      return std::unexpected(name + ": not a path in the MPCDI's folder");
    for (const auto& part : rel)
      if (part == "..") return std::unexpected(name + ": not a path in the MPCDI's folder");
    auto bytes = slurp(impl_->folder / rel, maxBytes);
    if (!bytes) return std::unexpected(name + ": " + bytes.error() + " (beside the mpcdi.xml)");
    return bytes;
  }
  zip_stat_t st;
  zip_stat_init(&st);
  if (zip_stat(impl_->zip, name.c_str(), 0, &st) != 0)
    return std::unexpected("no " + name + " in the archive");
  if ((st.valid & ZIP_STAT_SIZE) == 0 || st.size > maxBytes)
    return std::unexpected(name + ": larger than " + std::to_string(maxBytes) + " bytes");
  zip_file_t* f = zip_fopen(impl_->zip, name.c_str(), 0);
  if (f == nullptr) return std::unexpected(name + ": " + zip_strerror(impl_->zip));
  std::string bytes(static_cast<std::size_t>(st.size), '\0');
  std::size_t got = 0;
  while (got < bytes.size()) {
    const zip_int64_t n = zip_fread(f, bytes.data() + got, bytes.size() - got);
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  const bool ok = got == bytes.size();
  std::string why = ok ? std::string() : zip_file_strerror(f);
  zip_fclose(f);
  if (!ok) return std::unexpected(name + ": cannot be inflated: " + why);
  return bytes;
}

} // namespace tellus::mpcdi::detail

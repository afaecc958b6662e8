// The atmosphere's tables on disk (AtmosphereCache.hpp): a keyed file, checked field by field and
// by a hash of its bytes, written through a temporary file and rename(2).
#include <tellus/planet/AtmosphereCache.hpp>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <system_error>
#include <unistd.h>
#include <vector>

namespace tellus::planet {

namespace {

constexpr std::array<char, 8> kMagic{'T', 'E', 'L', 'L', 'U', 'S', 'A', 'T'};

/** FNV-1a, 64 bits. */
struct Fnv {
  std::uint64_t h = 1469598103934665603ull;
  void add(const void* data, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= b[i];
      h *= 1099511628211ull;
    }
  }
};

/** Appends n bytes to out. */
void append(std::vector<char>& out, const void* data, std::size_t n) {
  const std::size_t at = out.size();
  out.resize(at + n);
  if (n > 0) std::memcpy(out.data() + at, data, n);
}

/** Every field that determines the tables, in a fixed order: the file's header. */
std::vector<char> describe(const AtmosphereParameters& p, const AtmosphereTableSizes& s) {
  std::vector<char> out;
  auto put = [&](const auto& v) { append(out, &v, sizeof(v)); };
  put(kAtmosphereCacheVersion);
  for (double d : {p.bottomRadiusM,
                   p.topAltitudeM,
                   p.rayleighScaleHeightM,
                   p.mieScattering,
                   p.mieExtinction,
                   p.mieScaleHeightM,
                   p.miePhaseG,
                   p.ozoneCentreM,
                   p.ozoneHalfWidthM,
                   p.sunAngularRadiusRad,
                   p.muSMin})
    put(d);
  for (const glm::dvec3& v :
       {p.rayleighScattering, p.ozoneAbsorption, p.solarIrradiance, p.groundAlbedo})
    for (int c = 0; c < 3; ++c)
      put(v[c]);
  for (int i : {s.transmittanceW,
                s.transmittanceH,
                s.scatteringR,
                s.scatteringMu,
                s.scatteringMuS,
                s.scatteringNu,
                s.multipleW,
                s.multipleH,
                s.samples})
    put(i);
  return out;
}

std::uint64_t hashOf(const std::vector<char>& bytes) {
  Fnv f;
  f.add(bytes.data(), bytes.size());
  return f.h;
}

/** Reads a float table from `pos` (its count, then its floats) before `end`; false when short or
 * the count is not `want`. */
bool readTable(const std::vector<char>& data,
               std::size_t& pos,
               std::size_t end,
               std::size_t want,
               std::vector<float>& out) {
  std::uint64_t n = 0;
  if (end - pos < sizeof(n)) return false;
  std::memcpy(&n, data.data() + pos, sizeof(n));
  pos += sizeof(n);
  if (n != want || (end - pos) / sizeof(float) < n) return false;
  out.resize(want);
  std::memcpy(out.data(), data.data() + pos, want * sizeof(float));
  pos += want * sizeof(float);
  return true;
}

} // namespace

std::string atmosphereCacheKey(const AtmosphereParameters& p, const AtmosphereTableSizes& s) {
  char text[17];
  std::snprintf(
      text, sizeof(text), "%016llx", static_cast<unsigned long long>(hashOf(describe(p, s))));
  return text;
}

std::filesystem::path atmosphereCacheFile(const std::filesystem::path& dir,
                                          const AtmosphereParameters& p,
                                          const AtmosphereTableSizes& s) {
  return dir / ("atmosphere-" + atmosphereCacheKey(p, s) + ".bin");
}

std::expected<AtmosphereTables, std::string> loadAtmosphereTables(const std::filesystem::path& file,
                                                                  const AtmosphereParameters& p,
                                                                  const AtmosphereTableSizes& s) {
  const auto start = std::chrono::steady_clock::now();
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) return std::unexpected("no file " + file.string());
  const std::streamoff size = in.tellg();
  if (size < 0) return std::unexpected("cannot read " + file.string());
  std::vector<char> data(static_cast<std::size_t>(size));
  in.seekg(0);
  if (!in.read(data.data(), size)) return std::unexpected("cannot read " + file.string());
  const std::vector<char> head = describe(p, s);
  const std::size_t fixed = kMagic.size() + head.size();
  if (data.size() < fixed + sizeof(std::uint64_t))
    return std::unexpected(file.string() + " is too short");
  if (std::memcmp(data.data(), kMagic.data(), kMagic.size()) != 0)
    return std::unexpected(file.string() + " is not a tellus atmosphere file");
  if (std::memcmp(data.data() + kMagic.size(), head.data(), head.size()) != 0)
    return std::unexpected(file.string() + " holds another atmosphere or format version");
  const std::size_t body = data.size() - sizeof(std::uint64_t);
  Fnv f;
  f.add(data.data(), body);
  std::uint64_t stored = 0;
  std::memcpy(&stored, data.data() + body, sizeof(stored));
  if (stored != f.h) return std::unexpected(file.string() + " is corrupt (its hash differs)");
  auto count = [](int a, int b, int c = 1) {
    return static_cast<std::size_t>(a) * static_cast<std::size_t>(b) * static_cast<std::size_t>(c) *
           3;
  };
  const std::size_t scattering =
      count(s.scatteringNu * s.scatteringMuS, s.scatteringMu, s.scatteringR);
  std::vector<float> transmittance, scatter, mie, multiple;
  std::size_t pos = fixed;
  if (!readTable(data, pos, body, count(s.transmittanceW, s.transmittanceH), transmittance) ||
      !readTable(data, pos, body, scattering, scatter) ||
      !readTable(data, pos, body, scattering, mie) ||
      !readTable(data, pos, body, count(s.multipleW, s.multipleH), multiple) || pos != body)
    return std::unexpected(file.string() + " has tables of other sizes");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return AtmosphereTables::fromData(p,
                                    s,
                                    std::move(transmittance),
                                    std::move(scatter),
                                    std::move(mie),
                                    std::move(multiple),
                                    seconds);
}

std::expected<void, std::string> saveAtmosphereTables(const AtmosphereTables& tables,
                                                      const std::filesystem::path& file) {
  std::error_code ec;
  std::filesystem::create_directories(file.parent_path(), ec);
  if (ec)
    return std::unexpected("cannot make " + file.parent_path().string() + ": " + ec.message());
  std::vector<char> data;
  append(data, kMagic.data(), kMagic.size());
  const std::vector<char> head = describe(tables.parameters(), tables.sizes());
  append(data, head.data(), head.size());
  for (const std::vector<float>* t : {&tables.transmittanceTable(),
                                      &tables.scatteringTable(),
                                      &tables.mieTable(),
                                      &tables.multipleTable()}) {
    const std::uint64_t n = t->size();
    append(data, &n, sizeof(n));
    append(data, t->data(), t->size() * sizeof(float));
  }
  Fnv f;
  f.add(data.data(), data.size());
  append(data, &f.h, sizeof(f.h));
  // A temporary name of this process in the same folder (rename is atomic within a filesystem).
  const std::filesystem::path tmp =
      file.parent_path() / (file.filename().string() + ".tmp." + std::to_string(::getpid()));
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(data.data(), static_cast<std::streamsize>(data.size()));
    out.flush();
    if (!out) {
      std::filesystem::remove(tmp, ec);
      return std::unexpected("cannot write " + tmp.string());
    }
  }
  std::filesystem::rename(tmp, file, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return std::unexpected("cannot rename " + tmp.string() + " to " + file.string());
  }
  return {};
}

AtmosphereCacheResult cachedAtmosphereTables(const std::filesystem::path& dir,
                                             const AtmosphereParameters& p,
                                             const AtmosphereTableSizes& s,
                                             int threads) {
  if (dir.empty()) return {AtmosphereTables::precompute(p, s, threads), false, ""};
  const std::filesystem::path file = atmosphereCacheFile(dir, p, s);
  auto loaded = loadAtmosphereTables(file, p, s);
  if (loaded) return {std::move(*loaded), true, ""};
  AtmosphereCacheResult r{AtmosphereTables::precompute(p, s, threads), false, loaded.error()};
  if (auto saved = saveAtmosphereTables(r.tables, file); !saved) r.note += "; " + saved.error();
  return r;
}

} // namespace tellus::planet

#pragma once
/**
 * @file Geoid.hpp
 * @brief The EGM96 geoid: how far mean sea level lies above the WGS84 ellipsoid, and the switch
 * that moves heights of a mean-sea-level dataset onto the ellipsoid (GeographicLib stays private).
 *
 * Heights in ETOPO, SRTM and most DEMs are orthometric (H, above the geoid, "mean sea level"); the
 * renderer places points on the ellipsoid (h). With the geoid undulation N (metres, -107 to +85
 * for EGM96): h = H + N. The bundled grid is `data/egm96-30.pgm` (EGM96 at 30', GeographicLib's PGM
 * format, made from PROJ's egm96_15.gtx by tools/geoid_gtx_to_pgm.py; see data/README.md).
 */

#include <expected>
#include <filesystem>
#include <memory>
#include <span>
#include <string>

namespace tellus {

/** The bundled grid's file name in the data directory. */
inline constexpr const char* kGeoidFileName = "egm96-30.pgm";

/** Thread safety: the whole grid is read at open(); immutable after, all methods may be called
 * concurrently. Move-only. */
class Geoid {
public:
  enum class Interpolation {
    Bilinear, ///< exact at the grid's nodes
    Cubic,    ///< GeographicLib's 12-point cubic fit (smoother, not exact at nodes)
  };

  /** Reads a GeographicLib PGM geoid grid. A message naming the file when it is missing or not
   * such a grid. */
  static std::expected<Geoid, std::string>
  open(const std::filesystem::path& pgmFile, Interpolation interpolation = Interpolation::Bilinear);

  ~Geoid();
  Geoid(Geoid&&) noexcept;
  Geoid& operator=(Geoid&&) noexcept;

  /** Geoid undulation N in metres (the geoid's height above the WGS84 ellipsoid). Latitude in
   * [-90, 90], longitude any finite value (wraps); anything else (NaN, inf, |lat| > 90) gives NaN.
   */
  double undulationM(double latDeg, double lonDeg) const noexcept;
  /** N along a parallel: out[i] = undulationM(latDeg, lon0Deg + i * dLonDeg) up to rounding
   * (1e-9 m). With bilinear interpolation N is linear in longitude between two of the grid's
   * meridians, so only the meridians the row crosses are looked up (a 150-sample row inside one 30'
   * cell: two lookups instead of 150); cubic: one lookup per sample. NaN as above. */
  void undulationsAlongParallel(double latDeg,
                                double lon0Deg,
                                double dLonDeg,
                                std::span<double> out) const noexcept;
  /** h = H + N: a height above mean sea level as a height above the ellipsoid (NaN as above). */
  double ellipsoidHeightM(double latDeg, double lonDeg, double mslHeightM) const noexcept;
  /** H = h - N: the inverse. */
  double mslHeightM(double latDeg, double lonDeg, double ellipsoidHeightM) const noexcept;

  Interpolation interpolation() const noexcept;
  /** The file's Description line. */
  std::string description() const;
  /** The file's own figure for the largest interpolation error of this interpolation in metres
   * (MaxBilinearError / MaxCubicError); -1 when the file does not say. */
  double statedMaxErrorM() const noexcept;

private:
  struct Impl;
  explicit Geoid(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/**
 * @brief The switch between mean-sea-level heights and ellipsoid heights (config `renderer.geoid`).
 *
 * Off (default constructed): heights are taken as heights above the ellipsoid, h = H (up to ~107 m
 * off, the geoid ignored). On: h = H + N(lat, lon) from the geoid. Copies share the geoid.
 */
class VerticalDatum {
public:
  VerticalDatum() = default;
  explicit VerticalDatum(std::shared_ptr<const Geoid> geoid) : geoid_(std::move(geoid)) {}

  bool usesGeoid() const noexcept { return geoid_ != nullptr; }
  /** The geoid, or null when off. */
  const Geoid* geoid() const noexcept { return geoid_.get(); }
  /** The height above the ellipsoid of a height above mean sea level at lat/lon (NaN in, NaN out;
   * with the geoid off it is the height itself). */
  double ellipsoidHeightM(double latDeg, double lonDeg, double mslHeightM) const noexcept;

private:
  std::shared_ptr<const Geoid> geoid_;
};

} // namespace tellus

#pragma once
/**
 * @file StarCatalogue.hpp
 * @brief The star background's data (issue 23): a catalogue of bright stars (the bundled
 * data/stars-hip-6.5.txt, Hipparcos stars to V = 6.5 from d3-celestial; data/README.md), where each
 * star lies in the Earth-fixed frame at a time, and how bright and what colour the renderer draws
 * it. GL-free; the GL layer's StarsPass (planet/gl/src/StarsPass.hpp) draws what this gives.
 *
 * The file: text, one star a line, `HIP RA_deg Dec_deg Vmag B-V` separated by spaces (RA in
 * [0, 360), Dec in [-90, 90] degrees, J2000/ICRS; V magnitude; B-V colour index or `-` when
 * unknown); lines starting with '#' and blank lines are skipped. Anything else is refused with the
 * file's name and line number.
 *
 * Placement: a star's J2000 unit vector (astro::equatorialDirection) turned into ECEF by
 * astro::celestialToEcef(time) (precession and Greenwich mean sidereal time): the sky turns once
 * per sidereal day about ECEF +z. Stars are at infinity: the renderer uses only this direction
 * (camera-relative, no position), so parallax and the observer's place do not enter. Proper
 * motion is not applied (Hipparcos positions are for epoch J1991.25; the fastest bright stars move
 * under 10 arc seconds a year), nor aberration (20 arc seconds) or refraction.
 *
 * Brightness: a star's pixels sum to its energy E (in units of one full-white pixel, per channel
 * before the colour is applied), E = brightness x kStarEnergyMag0 x 10^(-0.4 m /
 * kStarDisplayGamma), capped at kStarEnergyCap. Flux goes as 10^(-0.4 m); the framebuffer's 8-bit
 * values are shown through the display's gamma (about 2.2: light ~ value^2.2), so value sums ~
 * flux^(1 / 2.2) keep the flux ratios between stars on the screen while magnitudes -1.5 to 6.5 (a
 * factor of 1,585 in flux) fit the 8-bit range (a factor of 28.5 in value). The cap keeps the
 * footprint's peak at most 1 (a full pixel), so no star clips: E_cap = 2 pi sigma^2 with sigma =
 * kStarSigmaPx. At the default brightness (1) Sirius sums to 3.7 full pixels (peak 0.92) and a V
 * = 6.5 star to 0.13 (peak 8 of 255).
 *
 * Colour: B-V to an effective temperature (Ballesteros 2012, "New insights into black bodies",
 * EPL 97 34008), the temperature to CIE 1931 chromaticity on the Planckian locus (the cubic fit of
 * Kim et al. 2002, 1667 K to 25000 K), to linear sRGB (IEC 61966-2-1, D65), scaled so that the
 * largest channel is 1, then encoded with sRGB's transfer curve (the framebuffer's values are shown
 * as sRGB, like the imagery's): Sirius (10,000 K) comes out (0.80, 0.85, 1), Betelgeuse (3,800 K)
 * (1, 0.81, 0.61). Unknown B-V: white.
 *
 * Immutable after reading; safe to share between threads.
 */

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tellus::planet {

/** The bundled catalogue's file name in the data directory. */
inline constexpr const char* kStarCatalogueFileName = "stars-hip-6.5.txt";

/** The sky's time when the scene has none (RendererOptions::timeUnixSeconds nullopt): J2000.0,
 * 2000-01-01T12:00:00 UTC (TT - UTC taken as 0, as Astronomy.hpp does), POSIX seconds. */
inline constexpr double kJ2000UnixSeconds = 946728000.0;

/** The footprint: a Gaussian of this standard deviation in pixels, whatever the view (fixed in
 * pixels, so that turning the camera moves energy smoothly between pixels; at 0.8 px sampled at
 * pixel centres its sum is within 1e-5 of its integral wherever its centre lies). */
inline constexpr double kStarSigmaPx = 0.8;
inline constexpr double kStarEnergyMag0 = 2.0;   ///< E of a V = 0 star at brightness 1 (pixels)
inline constexpr double kStarDisplayGamma = 2.2; ///< see the file comment
/** The largest energy: a peak of exactly 1 (2 pi sigma^2 full pixels). */
inline constexpr double kStarEnergyCap = 2.0 * 3.14159265358979323846 * kStarSigmaPx * kStarSigmaPx;

struct Star {
  std::int32_t hip = 0;     ///< Hipparcos number
  double raRad = 0.0;       ///< right ascension, J2000, [0, 2 pi)
  double decRad = 0.0;      ///< declination, J2000, [-pi/2, pi/2]
  double vmag = 0.0;        ///< apparent V magnitude
  std::optional<double> bv; ///< B-V colour index (magnitudes); nullopt: unknown
};

class StarCatalogue {
public:
  /** Reads a catalogue file; the error names the file (missing, unreadable, or the first bad line
   * and why). */
  static std::expected<StarCatalogue, std::string> open(const std::filesystem::path& file);
  /** Parses catalogue text; `name` is used in error messages ("<name>:<line>: ..."). An empty
   * catalogue is refused. */
  static std::expected<StarCatalogue, std::string> parse(std::string_view text,
                                                         std::string_view name);
  /** A catalogue of these stars (tests; a subset of another). */
  explicit StarCatalogue(std::vector<Star> stars) : stars_(std::move(stars)) {}

  const std::vector<Star>& stars() const noexcept { return stars_; }
  std::size_t size() const noexcept { return stars_.size(); }
  /** The star with this Hipparcos number, or null. */
  const Star* find(std::int32_t hip) const noexcept;

private:
  std::vector<Star> stars_;
};

/** The star's unit direction in the J2000 celestial frame. */
glm::dvec3 starCelestialDirection(const Star& star) noexcept;
/** The star's unit direction in ECEF at a time (POSIX seconds, UTC):
 * astro::celestialToEcef(unixSeconds) * starCelestialDirection(star). */
glm::dvec3 starDirectionEcef(const Star& star, double unixSeconds) noexcept;

/** The summed pixel value of a star of V magnitude vmag (see the file comment), >= 0, at most
 * kStarEnergyCap; brightness >= 0 multiplies it before the cap. */
double starEnergy(double vmag, double brightness) noexcept;
/** sRGB-encoded RGB, largest channel 1, of a star of this B-V (nullopt: white). B-V is clamped to
 * [-0.4, 2.0] (the temperature range of the fits). */
std::array<double, 3> starColour(std::optional<double> bv) noexcept;
/** The effective temperature (kelvin) of a star of this B-V (Ballesteros 2012). */
double starTemperatureK(double bv) noexcept;

} // namespace tellus::planet

// The bodies' IAU geographic CRS codes (BodyCrs.hpp).
#include <tellus/proxy/BodyCrs.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>

namespace tellus {

namespace {

// NAIF id x 100 (IAU 2015 codes, Archinal et al. 2018); mean radii from that report, metres.
constexpr std::array kBodies{
    BodyCrs{"mercury", 19900, 2439400.0},
    BodyCrs{"venus", 29900, 6051800.0},
    BodyCrs{"moon", 30100, 1737400.0},
    BodyCrs{"mars", 49900, 3396190.0},
    BodyCrs{"phobos", 40100, 11080.0},
    BodyCrs{"deimos", 40200, 6200.0},
    BodyCrs{"io", 50100, 1821490.0},
    BodyCrs{"europa", 50200, 1560800.0},
    BodyCrs{"ganymede", 50300, 2631200.0},
    BodyCrs{"callisto", 50400, 2410300.0},
    BodyCrs{"enceladus", 60200, 252100.0},
    BodyCrs{"titan", 60600, 2575000.0},
    BodyCrs{"pluto", 99900, 1188300.0},
};

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return out;
}

std::optional<std::int32_t> code(std::string_view digits) {
  std::int32_t v = 0;
  const auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
  if (ec != std::errc{} || p != digits.data() + digits.size() || digits.empty() || v <= 0)
    return std::nullopt;
  return v;
}

} // namespace

std::optional<BodyCrs> bodyCrs(std::string_view body) {
  const std::string b = lower(body);
  for (const BodyCrs& c : kBodies)
    if (c.body == b) return c;
  return std::nullopt;
}

std::optional<std::int32_t> parseIauCrs(std::string_view crs) {
  const std::string c = lower(crs);
  for (const std::string_view prefix : {"iau:2015:", "iau_2015:", "iau2000:", "iau:"}) {
    if (c.starts_with(prefix)) return code(std::string_view(c).substr(prefix.size()));
  }
  return std::nullopt;
}

std::string iauCrs130(std::int32_t code) {
  return "IAU:" + std::to_string(code);
}

std::string iauCrs111(std::int32_t code) {
  return "IAU2000:" + std::to_string(code);
}

std::string iauCrsUrn(std::int32_t code) {
  return "urn:ogc:def:crs:IAU:2015:" + std::to_string(code);
}

} // namespace tellus

// The one redaction of every error a client sees (sanitizeForClient): credentials in their
// usual spellings, besides the URLs and paths TestOgcException covers.

#include <tellus/proxy/OgcExceptionFormat.hpp>

#include <gtest/gtest.h>

#include <string>

using namespace tellus;

TEST(Redaction, CredentialValuesAreRedacted) {
  EXPECT_EQ(sanitizeForClient("denied for apikey=SECRET123&LAYERS=a"),
            "denied for apikey=[redacted]&LAYERS=a");
  EXPECT_EQ(sanitizeForClient("GET ?SERVICE=WMS&api_key=S1&access_token=S2;sig=S3, done"),
            "GET ?SERVICE=WMS&api_key=[redacted]&access_token=[redacted];sig=[redacted], done");
  EXPECT_EQ(sanitizeForClient("password=hunter2 and Token=abc"),
            "password=[redacted] and Token=[redacted]");
  EXPECT_EQ(sanitizeForClient("header X-Api-Key: k-123 refused"),
            "header X-Api-Key: [redacted] refused");
  EXPECT_EQ(sanitizeForClient("Authorization: Bearer eyJhbGciOi.x.y was refused"),
            "Authorization: [redacted] was refused");
  EXPECT_EQ(sanitizeForClient("with Basic dXNlcjpwYXNz"), "with Basic [redacted]");
  // user:password@host without a scheme is an address with credentials.
  EXPECT_EQ(sanitizeForClient("connect to admin:hunter2@db.internal:5432 failed"),
            "connect to [url] failed");
  EXPECT_EQ(sanitizeForClient("at (ops:pw@10.1.2.3)"), "at ([url])");
}

TEST(Redaction, OrdinaryMessagesAreKept) {
  for (const char* keep : {"LAYERS=sat&STYLES=&FORMAT=image/jpeg",
                           "BBOX=-180,-90,180,90 is outside",
                           "write to ops@example.com",
                           "EPSG:4326 at 12:30",
                           "InvalidDimensionValue: TIME=2024-01-01",
                           "the key is missing",
                           "keyboard: none"}) {
    EXPECT_EQ(sanitizeForClient(keep), keep);
  }
}

TEST(RedactionExtremes, LongHostileInputsStayLinear) {
  std::string s;
  for (int i = 0; i < 20000; ++i)
    s += "a:";
  const std::string out = sanitizeForClient(s);
  EXPECT_EQ(out, s);
  std::string keys;
  for (int i = 0; i < 5000; ++i)
    keys += "key=" + std::to_string(i) + "&";
  EXPECT_EQ(sanitizeForClient(keys).find("key=1&"), std::string::npos);
}

// The one option parser of every command (config/CommandLine.hpp): typos are refused with a
// suggestion, never ignored (issue 21: `cache prune --layr fake` pruned every layer).
#include <tellus/config/CommandLine.hpp>

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace tellus::cli {
namespace {

CommandSpec pruneLike() {
  return {"cache",
          {{"config", OptionKind::Value},
           {"layer", OptionKind::Value},
           {"levels", OptionKind::Value},
           {"older-than", OptionKind::Value},
           {"overlay", OptionKind::Value, true},
           {"dry-run", OptionKind::Flag},
           {"dome", OptionKind::OptionalValue},
           {"wait-complete", OptionKind::OptionalValue}},
          1};
}

std::expected<Args, std::string> parseWords(const CommandSpec& spec,
                                            std::vector<std::string> words) {
  return parse(spec, words);
}

TEST(CommandLine, ValuesFlagsAndPositionals) {
  const auto a =
      parseWords(pruneLike(), {"prune", "--older-than", "0s", "--layer=bluemarble", "--dry-run"});
  ASSERT_TRUE(a) << a.error();
  EXPECT_EQ(a->positional, std::vector<std::string>{"prune"});
  EXPECT_EQ(a->get("older-than"), "0s");
  EXPECT_EQ(a->get("layer"), "bluemarble");
  EXPECT_TRUE(a->flag("dry-run"));
  EXPECT_FALSE(a->flag("levels"));
  EXPECT_EQ(a->get("levels"), std::nullopt);
}

TEST(CommandLine, AValueMayBeginWithADash) {
  // Negative coordinates: the next word is the value whatever it looks like.
  const auto a = parseWords(pruneLike(), {"--levels", "-10,-5,10,5"});
  ASSERT_TRUE(a) << a.error();
  EXPECT_EQ(a->get("levels"), "-10,-5,10,5");
}

TEST(CommandLine, UnknownOptionsAreRefusedWithASuggestion) {
  // The three typos, each once misread as "not given".
  auto e = parseWords(pruneLike(), {"prune", "--layr", "fake", "--older-than", "0s"});
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "unknown option --layr (did you mean --layer?)");
  e = parseWords(pruneLike(), {"--lvels", "0-0"});
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "unknown option --lvels (did you mean --levels?)");
  e = parseWords(pruneLike(), {"--no-such-flag", "1"});
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "unknown option --no-such-flag");
  // With a value attached, the name alone is judged.
  e = parseWords(pruneLike(), {"--older-then=1d"});
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "unknown option --older-then (did you mean --older-than?)");
  // A single dash is not an option prefix here; it is refused, not taken as a positional.
  e = parseWords(pruneLike(), {"-layer", "x"});
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "unknown option -layer (did you mean --layer?)");
  e = parseWords(pruneLike(), {"--", "x"});
  ASSERT_TRUE(e) << e.error();
  e = parseWords(pruneLike(), {"--=x"});
  ASSERT_FALSE(e);
}

TEST(CommandLine, MisuseOfKnownOptionsIsRefused) {
  auto e = parseWords(pruneLike(), {"--dry-run=yes"});
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "--dry-run takes no value, got '--dry-run=yes'");
  e = parseWords(pruneLike(), {"--layer"});
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "--layer needs a value");
  e = parseWords(pruneLike(), {"--layer", "a", "--layer", "b"});
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "--layer is given more than once");
  e = parseWords(pruneLike(), {"prune", "extra"});
  ASSERT_FALSE(e);
  EXPECT_EQ(e.error(), "unexpected argument 'extra'");
}

TEST(CommandLine, RepeatableOptionsKeepEveryValueInOrder) {
  const auto a = parseWords(pruneLike(), {"--overlay", "a,0.5", "--overlay=b", "--overlay", "c"});
  ASSERT_TRUE(a) << a.error();
  EXPECT_EQ(a->all("overlay"), (std::vector<std::string>{"a,0.5", "b", "c"}));
}

TEST(CommandLine, OptionalValues) {
  auto a = parseWords(pruneLike(), {"--dome", "--layer", "x"});
  ASSERT_TRUE(a) << a.error();
  EXPECT_TRUE(a->flag("dome"));
  EXPECT_EQ(a->get("dome"), "");
  a = parseWords(pruneLike(), {"--dome", "200"});
  ASSERT_TRUE(a) << a.error();
  EXPECT_EQ(a->get("dome"), "200");
  EXPECT_TRUE(a->positional.empty());
  a = parseWords(pruneLike(), {"--wait-complete=30", "--dome"});
  ASSERT_TRUE(a) << a.error();
  EXPECT_EQ(a->get("wait-complete"), "30");
  EXPECT_EQ(a->get("dome"), "");
}

TEST(CommandLine, EditDistanceCountsTranspositionsOnce) {
  EXPECT_EQ(editDistance("", ""), 0U);
  EXPECT_EQ(editDistance("layer", "layer"), 0U);
  EXPECT_EQ(editDistance("layr", "layer"), 1U);
  EXPECT_EQ(editDistance("lyaer", "layer"), 1U);
  EXPECT_EQ(editDistance("", "abc"), 3U);
  EXPECT_EQ(editDistance("kitten", "sitting"), 3U);
}

TEST(CommandLine, SuggestionsOnlyForCloseNames) {
  const std::vector<std::string_view> known = {"layer", "levels", "overlay", "older-than"};
  EXPECT_EQ(closestName("layr", known), "layer");
  EXPECT_EQ(closestName("levles", known), "levels");
  EXPECT_EQ(closestName("over", known), "overlay"); // a unique prefix
  EXPECT_EQ(closestName("l", known), std::nullopt); // a prefix of two: ambiguous
  EXPECT_EQ(closestName("completely-else", known), std::nullopt);
}

} // namespace
} // namespace tellus::cli

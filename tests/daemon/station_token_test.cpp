// The station token: made once in a 0640 file, the same after a restart, replaced only by rotate(),
// and absent when cmmd.json configures tokens.
#include "daemon/station_token.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <fstream>

#include "tests/daemon/fresh_folder.hpp"

namespace cmm::daemon {
namespace {

namespace fs = std::filesystem;

std::string first_line(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  return line;
}

unsigned mode_of(const fs::path& file) {
  struct stat st {};
  return ::stat(file.c_str(), &st) == 0 ? st.st_mode & 0777 : 0;
}

TEST(StationToken, IsMadeOnceInA0640FileAndTheSameAfterARestart) {
  const fs::path dir = fresh_folder("station-token");
  const fs::path file = dir / "operator.token";
  TokenBook book({}, 5, 20);
  StationToken first(book, file);
  const std::string token = first.set_up();
  EXPECT_EQ(token.size(), 64u);
  EXPECT_TRUE(std::all_of(token.begin(), token.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); }));
  EXPECT_EQ(first_line(file), token);
  EXPECT_EQ(mode_of(file), 0640u);
  EXPECT_EQ(book.check(token, "t").role, Role::operator_);
  EXPECT_FALSE(book.any_configured());

  TokenBook after_restart({}, 5, 20);
  StationToken second(after_restart, file);
  EXPECT_EQ(second.set_up(), token) << "a restart keeps the token: open tabs keep their STOP";
  EXPECT_EQ(after_restart.check(token, "t").role, Role::operator_);

  const std::string rotated = second.rotate();
  EXPECT_NE(rotated, token);
  EXPECT_EQ(first_line(file), rotated);
  EXPECT_EQ(mode_of(file), 0640u);
  EXPECT_FALSE(after_restart.check(token, "t").role) << "the old token is refused after a rotation";
  EXPECT_EQ(after_restart.check(rotated, "t").role, Role::operator_);
}

TEST(StationToken, AFileThatHoldsNoTokenIsReplacedAndConfiguredTokensRemoveIt) {
  const fs::path dir = fresh_folder("station-token-bad");
  const fs::path file = dir / "operator.token";
  std::ofstream(file) << "not a token\n";
  TokenBook book({}, 5, 20);
  const std::string token = StationToken(book, file).set_up();
  EXPECT_EQ(token.size(), 64u);
  EXPECT_EQ(first_line(file), token);

  TokenBook configured({{"observer-token-0123456789", Role::observer}}, 5, 20);
  StationToken none(configured, file);
  EXPECT_EQ(none.set_up(), "");
  EXPECT_FALSE(fs::exists(file)) << "a stale token must not mislead";
  EXPECT_FALSE(configured.check(token, "t").role);
  EXPECT_THROW(none.rotate(), std::logic_error);
}

}  // namespace
}  // namespace cmm::daemon

// The token book: the best role a token grants, the station token beside cmmd.json's, and wrong
// tokens throttled per source so that nobody's guessing ever refuses a right token.
#include "daemon/token_book.hpp"

#include <gtest/gtest.h>

#include "daemon/client/json_rpc.hpp"

namespace cmm::daemon {
namespace {

TEST(TokenBook, GrantsTheBestRoleAndTheStationTokenDoesNotCountAsConfigured) {
  TokenBook book({{"observer-token-0123456789", Role::observer}}, 5, 20);
  EXPECT_TRUE(book.any_configured());
  EXPECT_EQ(book.check("observer-token-0123456789", "a").role, Role::observer);
  EXPECT_FALSE(book.check("observer-token-012345678", "a").role);  // a prefix is not the token
  book.set_station_token("station-operator-token");
  EXPECT_EQ(book.check("station-operator-token", "a").role, Role::operator_);
  book.set_configured({});
  EXPECT_FALSE(book.any_configured());
  EXPECT_FALSE(book.check("observer-token-0123456789", "a").role);
  EXPECT_EQ(book.check("station-operator-token", "a").role, Role::operator_);  // kept over SIGHUP
  book.set_station_token("rotated-operator-token");
  EXPECT_FALSE(book.check("station-operator-token", "a").role) << "a rotated token is refused";
  EXPECT_EQ(book.check("rotated-operator-token", "a").role, Role::operator_);
}

TEST(TokenBook, ARightTokenIsNeverThrottledAndWrongOnesCountPerSource) {
  TokenBook book({{"observer-token-0123456789", Role::observer}, {"operator-token-0123456789", Role::operator_}}, 0.001, 2);
  EXPECT_FALSE(book.check("wrong-1", "flooder").throttled);
  EXPECT_FALSE(book.check("wrong-2", "flooder").throttled);
  const TokenCheck refused = book.check("wrong-3", "flooder");
  EXPECT_TRUE(refused.throttled);
  EXPECT_FALSE(refused.role);
  EXPECT_GT(refused.retry_after_s, 0);
  // The flooder's own right token, and anyone else's, still pass: compared first.
  EXPECT_EQ(book.check("observer-token-0123456789", "flooder").role, Role::observer);
  EXPECT_EQ(book.check("operator-token-0123456789", "operator").role, Role::operator_);
  // Another source's first wrong token is its own, not throttled by the flooder's.
  EXPECT_FALSE(book.check("typo", "operator").throttled);
}

TEST(TokenBook, ASourcePerGuessCostsABoundedBook) {
  TokenBook book({{"operator-token-0123456789", Role::operator_}}, 5, 20);
  for (int i = 0; i < 20000; ++i) EXPECT_FALSE(book.check("wrong", "connection " + std::to_string(i)).role);
  EXPECT_EQ(book.check("operator-token-0123456789", "connection 0").role, Role::operator_);
}

TEST(AuthSource, IsThePeersAddressWithoutItsPort) {
  EXPECT_EQ(auth_source("tcp://127.0.0.1:50412"), "tcp://127.0.0.1");
  EXPECT_EQ(auth_source("ws://[::1]:7621"), "ws://[::1]");
  EXPECT_EQ(auth_source("http://10.0.0.7:80"), "http://10.0.0.7");
  EXPECT_EQ(auth_source("tcp://[::1]"), "tcp://[::1]");
  EXPECT_EQ(auth_source("mqtt:ops"), "mqtt:ops");
  EXPECT_EQ(auth_source("unix:/run/cmmd/cmmd.sock (pid 7, uid 0)"), "unix:/run/cmmd/cmmd.sock (pid 7, uid 0)");
}

TEST(Authenticate, RaisesAndMarksTheContextAndClosesAfterThreeWrongTokens) {
  TokenBook book({{"operator-token-0123456789", Role::operator_}}, 5, 20);
  RpcContext ctx(1, "tcp://127.0.0.1:1", Role::none);
  EXPECT_FALSE(ctx.authenticated());
  for (int i = 1; i <= 3; ++i) {
    try {
      authenticate(book, "wrong-" + std::to_string(i), ctx, ctx.peer());
      ADD_FAILURE() << "a wrong token was accepted";
    } catch (const RpcError& e) {
      EXPECT_EQ(e.code(), rpc_code::auth_failed);
    }
    EXPECT_EQ(ctx.close_requested(), i == 3);
    EXPECT_EQ(ctx.role(), Role::none);
  }
  RpcContext next(2, "tcp://127.0.0.1:2", Role::none);
  EXPECT_EQ(authenticate(book, "operator-token-0123456789", next, next.peer()), Role::operator_);
  EXPECT_TRUE(next.authenticated());
  RpcContext unix_client(3, "unix:/x", Role::operator_, /*trusted=*/true);
  EXPECT_TRUE(unix_client.authenticated());
}

}  // namespace
}  // namespace cmm::daemon

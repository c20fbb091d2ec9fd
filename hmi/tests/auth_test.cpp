#include "fl/hmi/auth.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace fl::hmi {
namespace {

constexpr std::uint32_t kFewIterations = kMinPbkdf2Iterations;  // keeps the tests fast

TEST(PasswordHash, MatchesAnIndependentPbkdf2Sha256) {
  // Python: hashlib.pbkdf2_hmac('sha256', b'secret', b'saltsalt', 1000), base64.
  const std::vector<std::uint8_t> salt = {'s', 'a', 'l', 't', 's', 'a', 'l', 't'};
  EXPECT_EQ(hash_password_with_salt("secret", 1000, salt),
            "pbkdf2-sha256$1000$c2FsdHNhbHQ=$hgR9HsqtKupWxpnv8y99TrPDajTT/9PcSTlNafpdLXQ=");
}

TEST(PasswordHash, VerifiesTheRightPasswordOnly) {
  const std::string hash = hash_password("line 3 night shift", kFewIterations);
  EXPECT_TRUE(check_password_hash(hash).empty());
  EXPECT_TRUE(verify_password("line 3 night shift", hash));
  EXPECT_FALSE(verify_password("line 3 night shift ", hash));
  EXPECT_FALSE(verify_password("", hash));
  EXPECT_FALSE(verify_password("wrong", hash));
}

TEST(PasswordHash, SaltsEveryHash) {
  EXPECT_NE(hash_password("same", kFewIterations), hash_password("same", kFewIterations));
}

TEST(PasswordHash, RefusesWeakParameters) {
  EXPECT_THROW(hash_password("", kFewIterations), std::invalid_argument);
  EXPECT_THROW(hash_password("x", kMinPbkdf2Iterations - 1), std::invalid_argument);
}

TEST(PasswordHash, NamesWhatIsWrongWithAMalformedHash) {
  EXPECT_NE(check_password_hash("hunter2").find("not a password hash"), std::string::npos);
  EXPECT_NE(check_password_hash("md5$1000$c2FsdHNhbHQ=$aGFzaA==").find("unknown scheme"),
            std::string::npos);
  EXPECT_NE(check_password_hash("pbkdf2-sha256$ten$c2FsdHNhbHQ=$aGFzaA==").find("not a number"),
            std::string::npos);
  EXPECT_NE(check_password_hash("pbkdf2-sha256$10$c2FsdHNhbHQ=$aGFzaA==").find("minimum"),
            std::string::npos);
  EXPECT_NE(check_password_hash("pbkdf2-sha256$1000$c2FsdHNhbHQ=$aGFzaA==").find("32 bytes"),
            std::string::npos);
  EXPECT_THROW(verify_password("x", "hunter2"), std::invalid_argument);
}

TEST(ConstantTimeEqual, ComparesContentAndLength) {
  EXPECT_TRUE(constant_time_equal("abc", "abc"));
  EXPECT_TRUE(constant_time_equal("", ""));
  EXPECT_FALSE(constant_time_equal("abc", "abd"));
  EXPECT_FALSE(constant_time_equal("abc", "abcd"));
}

constexpr std::int64_t kSecond = 1'000'000'000;

TEST(SessionStore, TokenValidUntilIdleTimeout) {
  SessionStore sessions(60 * kSecond);
  const std::string token = sessions.create("operator", 0);
  EXPECT_EQ(token.size(), 64U);
  EXPECT_EQ(sessions.validate(token, 59 * kSecond), "operator");
  // Use refreshes the session: 59 s after the last use it is still valid.
  EXPECT_EQ(sessions.validate(token, 118 * kSecond), "operator");
  EXPECT_FALSE(sessions.validate(token, 179 * kSecond).has_value());
  EXPECT_FALSE(sessions.validate(token, 180 * kSecond).has_value());  // gone for good
  EXPECT_EQ(sessions.size(), 0U);
}

TEST(SessionStore, RefusesUnknownMissingAndRevokedTokens) {
  SessionStore sessions(60 * kSecond);
  const std::string token = sessions.create("operator", 0);
  std::string forged = token;
  forged[10] = forged[10] == 'a' ? 'b' : 'a';
  EXPECT_FALSE(sessions.validate("", 1).has_value());
  EXPECT_FALSE(sessions.validate(forged, 1).has_value());
  EXPECT_FALSE(sessions.validate(token.substr(1), 1).has_value());
  sessions.revoke(token);
  EXPECT_FALSE(sessions.validate(token, 1).has_value());
}

TEST(SessionStore, DropsTheLeastRecentlyUsedBeyondTheLimit) {
  SessionStore sessions(60 * kSecond, 2);
  const std::string first = sessions.create("operator", 0);
  const std::string second = sessions.create("operator", 1);
  EXPECT_TRUE(sessions.validate(first, 2).has_value());  // now second is the oldest in use
  const std::string third = sessions.create("operator", 3);
  EXPECT_TRUE(sessions.validate(first, 4).has_value());
  EXPECT_FALSE(sessions.validate(second, 4).has_value());
  EXPECT_TRUE(sessions.validate(third, 4).has_value());
}

TEST(LoginThrottle, LocksOutAnAddressAfterRepeatedFailures) {
  LoginThrottle throttle(3, 60 * kSecond, 30 * kSecond);
  for (int i = 0; i < 2; ++i) throttle.record_failure("10.0.0.9", i * kSecond);
  EXPECT_TRUE(throttle.allowed("10.0.0.9", 2 * kSecond));
  throttle.record_failure("10.0.0.9", 2 * kSecond);
  EXPECT_FALSE(throttle.allowed("10.0.0.9", 3 * kSecond));
  EXPECT_TRUE(throttle.allowed("10.0.0.7", 3 * kSecond));  // others are not affected
  EXPECT_TRUE(throttle.allowed("10.0.0.9", 32 * kSecond));
}

TEST(LoginThrottle, ForgetsFailuresOutsideTheWindowAndAfterSuccess) {
  LoginThrottle throttle(2, 10 * kSecond, 30 * kSecond);
  throttle.record_failure("a", 0);
  throttle.record_failure("a", 11 * kSecond);  // the first is outside the window
  EXPECT_TRUE(throttle.allowed("a", 12 * kSecond));
  throttle.record_success("a");
  throttle.record_failure("a", 13 * kSecond);
  EXPECT_TRUE(throttle.allowed("a", 14 * kSecond));
}

}  // namespace
}  // namespace fl::hmi

// Operator authentication for the HMI: salted PBKDF2-SHA256 password hashes (OpenSSL), session
// tokens with an idle timeout, and a per-address throttle on failed logins. Everything that
// compares secrets does it in constant time.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace fl::hmi {

// OWASP's 2023 figure for PBKDF2-HMAC-SHA256: about 0.3 s per login on a line PC.
inline constexpr std::uint32_t kDefaultPbkdf2Iterations = 600'000;
inline constexpr std::uint32_t kMinPbkdf2Iterations = 1'000;  // tests use few; never fewer

// "pbkdf2-sha256$<iterations>$<salt, base64>$<derived key, base64>" with a random 16-byte salt
// and a 32-byte key. Throws std::invalid_argument for an empty password or too few iterations.
std::string hash_password(std::string_view password,
                          std::uint32_t iterations = kDefaultPbkdf2Iterations);
// The same with a given salt (tests).
std::string hash_password_with_salt(std::string_view password, std::uint32_t iterations,
                                    const std::vector<std::uint8_t>& salt);

// Empty when `encoded` is a well-formed hash, else what is wrong with it (for config errors).
std::string check_password_hash(std::string_view encoded);
// False for a wrong password; throws std::invalid_argument for a malformed hash.
bool verify_password(std::string_view password, std::string_view encoded);

// Compares without an early exit, so the time does not tell how many leading bytes matched.
bool constant_time_equal(std::string_view a, std::string_view b);

// Logged-in sessions. Tokens are 32 random bytes, hex; a session ends after `idle_timeout_ns`
// without use or on logout. At most `max_sessions`: the least recently used one goes first.
// Thread-safe.
class SessionStore {
 public:
  explicit SessionStore(std::int64_t idle_timeout_ns, std::size_t max_sessions = 16);

  std::string create(const std::string& user, std::int64_t now_ns);
  // The session's user when the token is valid now (and then the session is refreshed).
  std::optional<std::string> validate(std::string_view token, std::int64_t now_ns);
  void revoke(std::string_view token);
  [[nodiscard]] std::size_t size() const;

 private:
  struct Session {
    std::string token;
    std::string user;
    std::int64_t last_used_ns = 0;
  };
  // Scans every session with a constant-time compare: no map lookup that leaks timing.
  std::vector<Session>::iterator find(std::string_view token);

  std::int64_t idle_timeout_ns_;
  std::size_t max_sessions_;
  mutable std::mutex mutex_;
  std::vector<Session> sessions_;
};

// After `max_failures` failed logins from one address within `window_ns`, that address is
// refused for `lockout_ns` (a guessing script slows to a crawl; the operator's own typo does
// not lock them out for long). Thread-safe.
class LoginThrottle {
 public:
  LoginThrottle(int max_failures, std::int64_t window_ns, std::int64_t lockout_ns);
  [[nodiscard]] bool allowed(const std::string& address, std::int64_t now_ns);
  void record_failure(const std::string& address, std::int64_t now_ns);
  void record_success(const std::string& address);

 private:
  struct Entry {
    int failures = 0;
    std::int64_t first_failure_ns = 0;
    std::int64_t locked_until_ns = 0;
  };
  int max_failures_;
  std::int64_t window_ns_;
  std::int64_t lockout_ns_;
  std::mutex mutex_;
  std::map<std::string, Entry> entries_;
};

}  // namespace fl::hmi

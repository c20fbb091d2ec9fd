#include "fl/hmi/auth.hpp"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>

#include <algorithm>
#include <charconv>
#include <stdexcept>
#include <variant>

namespace fl::hmi {
namespace {

constexpr std::string_view kScheme = "pbkdf2-sha256";
constexpr std::size_t kSaltBytes = 16;
constexpr std::size_t kKeyBytes = 32;
constexpr std::size_t kTokenBytes = 32;
constexpr std::size_t kMaxThrottledAddresses = 1024;

std::vector<std::uint8_t> random_bytes(std::size_t count) {
  std::vector<std::uint8_t> bytes(count);
  if (RAND_bytes(bytes.data(), static_cast<int>(count)) != 1) {
    throw std::runtime_error("OpenSSL RAND_bytes failed: no random source");
  }
  return bytes;
}

std::string base64_encode(const std::vector<std::uint8_t>& bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3), '\0');
  const int written = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()), bytes.data(),
                                      static_cast<int>(bytes.size()));
  out.resize(static_cast<std::size_t>(written));
  return out;
}

std::optional<std::vector<std::uint8_t>> base64_decode(std::string_view text) {
  if (text.empty() || text.size() % 4 != 0) return std::nullopt;
  const bool valid = std::all_of(text.begin(), text.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' ||
           c == '/' || c == '=';
  });
  if (!valid) return std::nullopt;
  std::vector<std::uint8_t> out(3 * text.size() / 4);
  const int written =
      EVP_DecodeBlock(out.data(), reinterpret_cast<const unsigned char*>(text.data()),
                      static_cast<int>(text.size()));
  if (written < 0) return std::nullopt;
  // EVP_DecodeBlock keeps the padding's zero bytes: drop one per '='.
  std::size_t length = static_cast<std::size_t>(written);
  for (auto it = text.rbegin(); it != text.rend() && *it == '='; ++it) --length;
  out.resize(length);
  return out;
}

std::vector<std::uint8_t> derive_key(std::string_view password, std::uint32_t iterations,
                                     const std::vector<std::uint8_t>& salt) {
  std::vector<std::uint8_t> key(kKeyBytes);
  if (PKCS5_PBKDF2_HMAC(password.data(), static_cast<int>(password.size()), salt.data(),
                        static_cast<int>(salt.size()), static_cast<int>(iterations), EVP_sha256(),
                        static_cast<int>(key.size()), key.data()) != 1) {
    throw std::runtime_error("OpenSSL PKCS5_PBKDF2_HMAC failed");
  }
  return key;
}

struct ParsedHash {
  std::uint32_t iterations = 0;
  std::vector<std::uint8_t> salt;
  std::vector<std::uint8_t> key;
};

// The parsed hash, or what is wrong with it.
std::variant<ParsedHash, std::string> parse_hash(std::string_view encoded) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = encoded.find('$', start);
    parts.push_back(encoded.substr(start, end == std::string_view::npos ? end : end - start));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  const std::string expected =
      "expected pbkdf2-sha256$ITERATIONS$SALT$KEY (from linectl hmi "
      "hash-password)";
  if (parts.size() != 4) return "not a password hash: " + expected;
  if (parts[0] != kScheme) return "unknown scheme '" + std::string(parts[0]) + "': " + expected;
  ParsedHash parsed;
  const auto [end, error] =
      std::from_chars(parts[1].data(), parts[1].data() + parts[1].size(), parsed.iterations);
  if (error != std::errc{} || end != parts[1].data() + parts[1].size()) {
    return "iterations '" + std::string(parts[1]) + "' is not a number";
  }
  if (parsed.iterations < kMinPbkdf2Iterations) {
    return "iterations " + std::string(parts[1]) + " below the minimum " +
           std::to_string(kMinPbkdf2Iterations);
  }
  auto salt = base64_decode(parts[2]);
  if (!salt || salt->size() < 8) return "salt is not base64 of at least 8 bytes";
  auto key = base64_decode(parts[3]);
  if (!key || key->size() != kKeyBytes) return "key is not base64 of 32 bytes";
  parsed.salt = std::move(*salt);
  parsed.key = std::move(*key);
  return parsed;
}

std::string to_hex(const std::vector<std::uint8_t>& bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(2 * bytes.size());
  for (const std::uint8_t byte : bytes) {
    out.push_back(kDigits[byte >> 4]);
    out.push_back(kDigits[byte & 0xF]);
  }
  return out;
}

}  // namespace

std::string hash_password_with_salt(std::string_view password, std::uint32_t iterations,
                                    const std::vector<std::uint8_t>& salt) {
  if (password.empty()) throw std::invalid_argument("the password must not be empty");
  if (iterations < kMinPbkdf2Iterations) {
    throw std::invalid_argument("PBKDF2 iterations must be at least " +
                                std::to_string(kMinPbkdf2Iterations));
  }
  if (salt.size() < 8) throw std::invalid_argument("the salt must have at least 8 bytes");
  return std::string(kScheme) + "$" + std::to_string(iterations) + "$" + base64_encode(salt) + "$" +
         base64_encode(derive_key(password, iterations, salt));
}

std::string hash_password(std::string_view password, std::uint32_t iterations) {
  return hash_password_with_salt(password, iterations, random_bytes(kSaltBytes));
}

std::string check_password_hash(std::string_view encoded) {
  auto parsed = parse_hash(encoded);
  if (auto* problem = std::get_if<std::string>(&parsed)) return *problem;
  return {};
}

bool verify_password(std::string_view password, std::string_view encoded) {
  auto parsed = parse_hash(encoded);
  if (auto* problem = std::get_if<std::string>(&parsed)) throw std::invalid_argument(*problem);
  const ParsedHash& hash = std::get<ParsedHash>(parsed);
  const std::vector<std::uint8_t> key = derive_key(password, hash.iterations, hash.salt);
  return CRYPTO_memcmp(key.data(), hash.key.data(), kKeyBytes) == 0;
}

bool constant_time_equal(std::string_view a, std::string_view b) {
  // The lengths are not secret (tokens have a fixed length); the contents are.
  if (a.size() != b.size()) return false;
  return a.empty() || CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

// ---------------------------------------------------------------- sessions

SessionStore::SessionStore(std::int64_t idle_timeout_ns, std::size_t max_sessions)
    : idle_timeout_ns_(idle_timeout_ns), max_sessions_(max_sessions) {
  if (idle_timeout_ns <= 0) throw std::invalid_argument("session idle timeout must be > 0");
  if (max_sessions == 0) throw std::invalid_argument("max_sessions must be > 0");
}

std::vector<SessionStore::Session>::iterator SessionStore::find(std::string_view token) {
  auto found = sessions_.end();
  for (auto it = sessions_.begin(); it != sessions_.end(); ++it) {
    if (constant_time_equal(it->token, token)) found = it;
  }
  return found;
}

std::string SessionStore::create(const std::string& user, std::int64_t now_ns) {
  std::string token = to_hex(random_bytes(kTokenBytes));
  const std::lock_guard lock(mutex_);
  std::erase_if(sessions_,
                [&](const Session& s) { return now_ns - s.last_used_ns > idle_timeout_ns_; });
  if (sessions_.size() >= max_sessions_) {
    sessions_.erase(std::min_element(
        sessions_.begin(), sessions_.end(),
        [](const Session& a, const Session& b) { return a.last_used_ns < b.last_used_ns; }));
  }
  sessions_.push_back(Session{token, user, now_ns});
  return token;
}

std::optional<std::string> SessionStore::validate(std::string_view token, std::int64_t now_ns) {
  if (token.size() != 2 * kTokenBytes) return std::nullopt;
  const std::lock_guard lock(mutex_);
  const auto it = find(token);
  if (it == sessions_.end()) return std::nullopt;
  if (now_ns - it->last_used_ns > idle_timeout_ns_) {
    sessions_.erase(it);
    return std::nullopt;
  }
  it->last_used_ns = now_ns;
  return it->user;
}

void SessionStore::revoke(std::string_view token) {
  const std::lock_guard lock(mutex_);
  const auto it = find(token);
  if (it != sessions_.end()) sessions_.erase(it);
}

std::size_t SessionStore::size() const {
  const std::lock_guard lock(mutex_);
  return sessions_.size();
}

// ---------------------------------------------------------------- throttle

LoginThrottle::LoginThrottle(int max_failures, std::int64_t window_ns, std::int64_t lockout_ns)
    : max_failures_(max_failures), window_ns_(window_ns), lockout_ns_(lockout_ns) {}

bool LoginThrottle::allowed(const std::string& address, std::int64_t now_ns) {
  const std::lock_guard lock(mutex_);
  const auto it = entries_.find(address);
  return it == entries_.end() || now_ns >= it->second.locked_until_ns;
}

void LoginThrottle::record_failure(const std::string& address, std::int64_t now_ns) {
  const std::lock_guard lock(mutex_);
  if (entries_.size() >= kMaxThrottledAddresses && !entries_.contains(address)) {
    // Forget addresses whose lockout and window are over; a flood of new addresses cannot
    // grow the table without bound.
    std::erase_if(entries_, [&](const auto& entry) {
      return now_ns >= entry.second.locked_until_ns &&
             now_ns - entry.second.first_failure_ns > window_ns_;
    });
    if (entries_.size() >= kMaxThrottledAddresses) entries_.erase(entries_.begin());
  }
  Entry& entry = entries_[address];
  if (entry.failures == 0 || now_ns - entry.first_failure_ns > window_ns_) {
    entry.failures = 0;
    entry.first_failure_ns = now_ns;
  }
  if (++entry.failures >= max_failures_) {
    entry.locked_until_ns = now_ns + lockout_ns_;
    entry.failures = 0;
  }
}

void LoginThrottle::record_success(const std::string& address) {
  const std::lock_guard lock(mutex_);
  entries_.erase(address);
}

}  // namespace fl::hmi

// The HMI server on a loopback port, driven by a plain socket client: logins, sessions and
// commands over HTTP and WebSocket, and the status push.
#include "fl/hmi/server.hpp"

#include <arpa/inet.h>
#include <dlfcn.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <optional>
#include <string>
#include <thread>

#include "fl/controller/line_config.hpp"
#include "fl/hmi/auth.hpp"
#include "fl/hmi/status_json.hpp"

namespace fl::hmi {
namespace {

constexpr std::int64_t kSecond = 1'000'000'000;
constexpr const char* kPassword = "fillets at 35 degrees";

// ---------------------------------------------------------------- a minimal client

class Socket {
 public:
  explicit Socket(int port) : fd_(socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
      throw std::runtime_error("connect to the HMI server failed");
    }
  }
  ~Socket() { close(fd_); }
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;

  void send_all(const std::string& data) const {
    std::size_t sent = 0;
    while (sent < data.size()) {
      const ssize_t n = ::send(fd_, data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) throw std::runtime_error("send failed");
      sent += static_cast<std::size_t>(n);
    }
  }
  // Up to `count` bytes, waiting at most 5 s; empty at end of stream or timeout.
  std::string receive(std::size_t count) const {
    pollfd readable{fd_, POLLIN, 0};
    if (poll(&readable, 1, 5000) <= 0) return {};
    std::string data(count, '\0');
    const ssize_t n = ::recv(fd_, data.data(), count, 0);
    data.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
    return data;
  }
  std::string receive_exactly(std::size_t count) const {
    std::string data;
    while (data.size() < count) {
      const std::string part = receive(count - data.size());
      if (part.empty()) throw std::runtime_error("stream ended early");
      data += part;
    }
    return data;
  }

 private:
  int fd_;
};

// clang-tidy 14 cannot prove nlohmann::json's implicit members noexcept.
struct HttpResponse {  // NOLINT(bugprone-exception-escape)
  int status = 0;
  std::string headers;
  nlohmann::json body;

  [[nodiscard]] std::string session_cookie() const {
    const std::string key = "Set-Cookie: fl_session=";
    const std::size_t at = headers.find(key);
    if (at == std::string::npos) return {};
    const std::size_t start = at + key.size();
    return headers.substr(start, headers.find(';', start) - start);
  }
};

struct RequestOptions {
  std::string cookie;
  std::string origin;
  std::string content_type = "application/json";
};
RequestOptions with(std::string cookie, std::string origin = {},
                    std::string content_type = "application/json") {
  return RequestOptions{std::move(cookie), std::move(origin), std::move(content_type)};
}

HttpResponse http(int port, const std::string& method, const std::string& path,
                  const std::string& body = {}, const RequestOptions& options = {}) {
  Socket socket(port);
  std::string request = method + " " + path +
                        " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                        "\r\nConnection: close\r\n";
  if (!options.cookie.empty()) request += "Cookie: fl_session=" + options.cookie + "\r\n";
  if (!options.origin.empty()) request += "Origin: " + options.origin + "\r\n";
  if (method == "POST") {
    request += "Content-Type: " + options.content_type +
               "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n";
  }
  socket.send_all(request + "\r\n" + body);
  std::string response;
  for (std::string part = socket.receive(4096); !part.empty(); part = socket.receive(4096)) {
    response += part;
  }
  HttpResponse parsed;
  const std::size_t header_end = response.find("\r\n\r\n");
  if (response.size() < 12 || header_end == std::string::npos) return parsed;
  parsed.status = std::stoi(response.substr(9, 3));
  parsed.headers = response.substr(0, header_end);
  parsed.body = nlohmann::json::parse(response.substr(header_end + 4), nullptr, false);
  return parsed;
}

// RFC 6455 client: handshake with optional cookie and origin, masked text frames out.
class WebSocketClient {
 public:
  WebSocketClient(int port, const std::string& cookie, const std::string& origin = {})
      : socket_(port) {
    std::string request = "GET /ws HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                          "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                          "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                          "Sec-WebSocket-Version: 13\r\n";
    if (!cookie.empty()) request += "Cookie: fl_session=" + cookie + "\r\n";
    if (!origin.empty()) request += "Origin: " + origin + "\r\n";
    socket_.send_all(request + "\r\n");
    std::string response;
    while (response.find("\r\n\r\n") == std::string::npos) {
      const std::string part = socket_.receive(1);
      if (part.empty()) break;
      response += part;
    }
    upgraded_ = response.rfind("HTTP/1.1 101", 0) == 0;
  }
  [[nodiscard]] bool upgraded() const { return upgraded_; }

  void send_text(const std::string& text) const {
    std::string frame;
    frame.push_back(static_cast<char>(0x81));  // FIN, text
    if (text.size() < 126) {
      frame.push_back(static_cast<char>(0x80 | text.size()));
    } else {
      frame.push_back(static_cast<char>(0x80 | 126));
      frame.push_back(static_cast<char>((text.size() >> 8) & 0xFF));
      frame.push_back(static_cast<char>(text.size() & 0xFF));
    }
    const std::array<char, 4> mask = {0x12, 0x34, 0x56, 0x78};
    frame.append(mask.data(), mask.size());
    for (std::size_t i = 0; i < text.size(); ++i) {
      frame.push_back(static_cast<char>(text[i] ^ mask[i % 4]));
    }
    socket_.send_all(frame);
  }

  // The next text message, skipping others; nullopt on timeout or close.
  std::optional<nlohmann::json> next_message() const {
    while (true) {
      const std::string head = socket_.receive_exactly(2);
      const int opcode = head[0] & 0x0F;
      std::uint64_t length = static_cast<std::uint8_t>(head[1]) & 0x7F;
      if (length == 126) {
        const std::string extended = socket_.receive_exactly(2);
        length = (std::uint64_t{static_cast<std::uint8_t>(extended[0])} << 8) |
                 static_cast<std::uint8_t>(extended[1]);
      } else if (length == 127) {
        const std::string extended = socket_.receive_exactly(8);
        length = 0;
        for (const char byte : extended) length = (length << 8) | static_cast<std::uint8_t>(byte);
      }
      const std::string payload = socket_.receive_exactly(static_cast<std::size_t>(length));
      if (opcode == 0x8) return std::nullopt;
      if (opcode == 0x1) return nlohmann::json::parse(payload);
    }
  }
  // The next message of one type.
  std::optional<nlohmann::json> next_of_type(const std::string& type) const {
    for (int i = 0; i < 100; ++i) {
      auto message = next_message();
      if (!message) return std::nullopt;
      if (message->value("type", "") == type) return message;
    }
    return std::nullopt;
  }

 private:
  Socket socket_;
  bool upgraded_ = false;
};

// ---------------------------------------------------------------- fixture

class HmiServerTest : public ::testing::Test {
 protected:
  void SetUp() override { start(hash_password(kPassword, kMinPbkdf2Iterations)); }

  void start(const std::string& password_hash, bool with_twin = false) {
    server_.reset();
    HmiConfig config;
    config.bind_address = "127.0.0.1";
    config.port = 0;
    config.document_root = std::string(FL_SOURCE_DIR) + "/hmi/www";
    config.publish_rate_hz = 50.0;
    config.session_idle_timeout_s = 60.0;
    config.operator_user = "operator";
    config.operator_password_hash = password_hash;
    config.login_max_failures = 3;
    HmiCommands commands;
    commands.start_line = [this] { ++starts_; };
    commands.stop_line = [this] { ++stops_; };
    commands.acknowledge_faults = [this] { ++acknowledges_; };
    if (with_twin) {
      commands.twin_fault = [this](std::string_view fault, std::string_view, bool active) {
        if (fault != "camera_silent") return std::string("unknown fault");
        twin_fault_active_ = active;
        return std::string();
      };
    }
    server_ = std::make_unique<HmiServer>(config, status_, layout_to_json(default_line_config()),
                                          commands, [this] { return now_ns_.load(); });
    server_->start();
    port_ = server_->port();
    ASSERT_GT(port_, 0);
  }

  std::string login() {
    const HttpResponse response =
        http(port_, "POST", "/api/login",
             R"({"user":"operator","password":")" + std::string(kPassword) + "\"}");
    EXPECT_EQ(response.status, 200);
    return response.session_cookie();
  }

  void publish_status(std::uint32_t fillets) {
    LineStatus& status = status_.back();
    status.time_ns = 5 * kSecond;
    status.state = LineState::kRunning;
    status.active_faults = fault_bit(FaultCode::kCameraSilent);
    status.tracked_count = fillets;
    for (std::uint32_t i = 0; i < fillets; ++i) {
      status.tracked[i].id = i + 1;
      status.tracked[i].s_mm = 100.0F * static_cast<float>(i);
    }
    status_.publish();
  }

  TripleBuffer<LineStatus> status_;
  std::unique_ptr<HmiServer> server_;
  int port_ = 0;
  std::atomic<std::int64_t> now_ns_{1000 * kSecond};
  std::atomic<int> starts_{0};
  std::atomic<int> stops_{0};
  std::atomic<int> acknowledges_{0};
  std::atomic<bool> twin_fault_active_{false};
};

TEST_F(HmiServerTest, ServesThePageToAnyone) {
  Socket socket(port_);
  socket.send_all("GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  std::string response;
  for (std::string part = socket.receive(4096); !part.empty(); part = socket.receive(4096)) {
    response += part;
  }
  EXPECT_EQ(response.rfind("HTTP/1.1 200", 0), 0U) << response.substr(0, 200);
  EXPECT_NE(response.find("<svg"), std::string::npos);
}

TEST_F(HmiServerTest, WrongPasswordOrUserGetsNoSession) {
  HttpResponse response =
      http(port_, "POST", "/api/login", R"({"user":"operator","password":"guess"})");
  EXPECT_EQ(response.status, 401);
  EXPECT_TRUE(response.session_cookie().empty());
  response = http(port_, "POST", "/api/login",
                  R"({"user":"admin","password":")" + std::string(kPassword) + "\"}");
  EXPECT_EQ(response.status, 401);
  EXPECT_TRUE(response.session_cookie().empty());
}

TEST_F(HmiServerTest, RightPasswordGivesAnHttpOnlySessionCookie) {
  const HttpResponse response =
      http(port_, "POST", "/api/login",
           R"({"user":"operator","password":")" + std::string(kPassword) + "\"}");
  ASSERT_EQ(response.status, 200);
  EXPECT_EQ(response.session_cookie().size(), 64U);
  EXPECT_NE(response.headers.find("HttpOnly"), std::string::npos);
  EXPECT_NE(response.headers.find("SameSite=Strict"), std::string::npos);
  const HttpResponse session =
      http(port_, "GET", "/api/session", {}, with(response.session_cookie()));
  EXPECT_EQ(session.body["authenticated"], true);
  EXPECT_EQ(session.body["user"], "operator");
}

TEST_F(HmiServerTest, CommandWithoutTokenIsRefused) {
  EXPECT_EQ(http(port_, "POST", "/api/command", R"({"command":"start"})").status, 401);
  EXPECT_EQ(http(port_, "POST", "/api/command", R"({"command":"stop"})", with("deadbeef")).status,
            401);
  EXPECT_EQ(http(port_, "POST", "/api/command", R"({"command":"acknowledge"})",
                 with(std::string(64, 'a')))
                .status,
            401);
  EXPECT_EQ(starts_ + stops_ + acknowledges_, 0);
}

TEST_F(HmiServerTest, CommandWithTokenRuns) {
  const std::string cookie = login();
  EXPECT_EQ(
      http(port_, "POST", "/api/command", R"({"command":"acknowledge"})", with(cookie)).status,
      200);
  EXPECT_EQ(http(port_, "POST", "/api/command", R"({"command":"stop"})", with(cookie)).status, 200);
  EXPECT_EQ(acknowledges_, 1);
  EXPECT_EQ(stops_, 1);
  const HttpResponse unknown =
      http(port_, "POST", "/api/command", R"({"command":"explode"})", with(cookie));
  EXPECT_EQ(unknown.status, 400);
  EXPECT_NE(unknown.body["error"].get<std::string>().find("unknown command"), std::string::npos);
}

TEST_F(HmiServerTest, ExpiredTokenIsRefused) {
  const std::string cookie = login();
  now_ns_ += 61 * kSecond;
  EXPECT_EQ(http(port_, "POST", "/api/command", R"({"command":"start"})", with(cookie)).status,
            401);
  EXPECT_EQ(starts_, 0);
}

TEST_F(HmiServerTest, LogoutEndsTheSession) {
  const std::string cookie = login();
  EXPECT_EQ(http(port_, "POST", "/api/logout", "{}", with(cookie)).status, 200);
  EXPECT_EQ(http(port_, "POST", "/api/command", R"({"command":"start"})", with(cookie)).status,
            401);
}

TEST_F(HmiServerTest, CrossSiteRequestsAreRefusedEvenWithASession) {
  const std::string cookie = login();
  EXPECT_EQ(http(port_, "POST", "/api/command", R"({"command":"start"})",
                 with(cookie, "http://evil.example"))
                .status,
            403);
  // A form post (no preflight) cannot carry the JSON content type.
  EXPECT_EQ(
      http(port_, "POST", "/api/command", R"({"command":"start"})", with(cookie, {}, "text/plain"))
          .status,
      415);
  EXPECT_EQ(starts_, 0);
  EXPECT_FALSE(WebSocketClient(port_, cookie, "http://evil.example").upgraded());
}

TEST_F(HmiServerTest, RepeatedFailedLoginsLockTheAddressOut) {
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(http(port_, "POST", "/api/login", R"({"user":"operator","password":"x"})").status,
              401);
  }
  EXPECT_EQ(http(port_, "POST", "/api/login",
                 R"({"user":"operator","password":")" + std::string(kPassword) + "\"}")
                .status,
            429);
  now_ns_ += 31 * kSecond;
  login();
}

TEST_F(HmiServerTest, NoConfiguredHashMeansReadOnly) {
  start("");
  EXPECT_EQ(http(port_, "POST", "/api/login", R"({"user":"operator","password":""})").status, 403);
}

TEST_F(HmiServerTest, WebSocketPushesStatusToAnyone) {
  WebSocketClient client(port_, "");
  ASSERT_TRUE(client.upgraded());
  const auto hello = client.next_of_type("hello");
  ASSERT_TRUE(hello);
  EXPECT_EQ((*hello)["authenticated"], false);
  ASSERT_TRUE(client.next_of_type("layout"));
  publish_status(3);
  const auto status = client.next_of_type("status");
  ASSERT_TRUE(status);
  EXPECT_EQ((*status)["state"], "running");
  EXPECT_EQ((*status)["fillets"].size(), 3U);
  EXPECT_EQ((*status)["faults"][0], "camera_silent");
  // The newest status is also there for a plain GET.
  EXPECT_EQ(http(port_, "GET", "/api/status").body["fillets"].size(), 3U);
}

TEST_F(HmiServerTest, WebSocketCommandWithoutTokenIsRefused) {
  WebSocketClient client(port_, "");
  ASSERT_TRUE(client.upgraded());
  client.send_text(R"({"type":"command","id":7,"command":"start"})");
  const auto result = client.next_of_type("command_result");
  ASSERT_TRUE(result);
  EXPECT_EQ((*result)["ok"], false);
  EXPECT_EQ((*result)["id"], 7);
  EXPECT_EQ((*result)["error"], "log in first");
  EXPECT_EQ(starts_, 0);
}

TEST_F(HmiServerTest, WebSocketCommandWithTokenRuns) {
  const std::string cookie = login();
  WebSocketClient client(port_, cookie, "http://127.0.0.1:" + std::to_string(port_));
  ASSERT_TRUE(client.upgraded());
  const auto hello = client.next_of_type("hello");
  ASSERT_TRUE(hello);
  EXPECT_EQ((*hello)["authenticated"], true);
  client.send_text(R"({"type":"command","id":1,"command":"start"})");
  const auto result = client.next_of_type("command_result");
  ASSERT_TRUE(result);
  EXPECT_EQ((*result)["ok"], true);
  EXPECT_EQ(starts_, 1);
  // The session is checked at every command, not only at the upgrade.
  now_ns_ += 61 * kSecond;
  client.send_text(R"({"type":"command","id":2,"command":"stop"})");
  const auto late = client.next_of_type("command_result");
  ASSERT_TRUE(late);
  EXPECT_EQ((*late)["ok"], false);
  EXPECT_EQ(stops_, 0);
}

TEST_F(HmiServerTest, TwinFaultsNeedATwinAndALogin) {
  const std::string cookie = login();
  const std::string raise = R"({"fault":"camera_silent","target":"orientation","active":true})";
  EXPECT_EQ(http(port_, "POST", "/api/twin/fault", raise, with(cookie)).status, 400);
  start(hash_password(kPassword, kMinPbkdf2Iterations), true);
  EXPECT_EQ(http(port_, "POST", "/api/twin/fault", raise).status, 401);
  EXPECT_FALSE(twin_fault_active_);
  EXPECT_EQ(http(port_, "POST", "/api/twin/fault", raise, with(login())).status, 200);
  EXPECT_TRUE(twin_fault_active_);
}

TEST(ThroughputMeter, PlacedPerMinuteOverTheLastMinute) {
  ThroughputMeter meter;
  EXPECT_FALSE(meter.placed_per_minute());
  for (int s = 0; s <= 120; ++s) meter.add(s * kSecond, static_cast<std::uint64_t>(s));
  ASSERT_TRUE(meter.placed_per_minute());
  EXPECT_NEAR(*meter.placed_per_minute(), 60.0, 1.5);
}

}  // namespace
}  // namespace fl::hmi

namespace fl::hmi {
namespace {

// civetweb asks for 100 KB worker stacks; the HMI raises every such request (server.cpp).
// The symbol is looked up the way the loader binds libcivetweb's reference to it (versioned,
// GLIBC_2.34, global scope): a plain call from this executable would not tell whether a
// shared library gets the override or libc's (the first version of the override passed a
// plain call and still crashed in linectl).
TEST(ThreadStack, SmallStackRequestsFromLibrariesAreRaised) {
  using SetStackSize = int (*)(pthread_attr_t*, std::size_t);
  const auto bound = reinterpret_cast<SetStackSize>(
      dlvsym(RTLD_DEFAULT, "pthread_attr_setstacksize", "GLIBC_2.34"));
  ASSERT_NE(bound, nullptr);
  pthread_attr_t attributes;
  ASSERT_EQ(pthread_attr_init(&attributes), 0);
  ASSERT_EQ(bound(&attributes, 102400), 0);
  std::size_t stack_bytes = 0;
  ASSERT_EQ(pthread_attr_getstacksize(&attributes, &stack_bytes), 0);
  EXPECT_GE(stack_bytes, std::size_t{1} << 20);
  pthread_attr_destroy(&attributes);
}

}  // namespace
}  // namespace fl::hmi

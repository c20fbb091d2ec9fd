#include "fl/hmi/server.hpp"

#include <civetweb.h>
#include <dlfcn.h>
#include <pthread.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

#include "fl/hmi/auth.hpp"
#include "fl/hmi/status_json.hpp"

namespace fl::hmi {
namespace {

constexpr const char* kSessionCookie = "fl_session";
constexpr std::size_t kMaxBodyBytes = 4096;  // every request the page sends is a few dozen bytes
constexpr std::int64_t kLoginWindowNs = 60'000'000'000;

std::int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

const char* reason_phrase(int status) {
  switch (status) {
    case 200:
      return "OK";
    case 400:
      return "Bad Request";
    case 401:
      return "Unauthorized";
    case 403:
      return "Forbidden";
    case 404:
      return "Not Found";
    case 405:
      return "Method Not Allowed";
    case 413:
      return "Payload Too Large";
    case 415:
      return "Unsupported Media Type";
    case 429:
      return "Too Many Requests";
    case 500:
      return "Internal Server Error";
    case 503:
      return "Service Unavailable";
    default:
      return "Error";
  }
}

void send_json(mg_connection* conn, int status, const nlohmann::json& body,
               const std::string& extra_headers = {}) {
  const std::string text = body.dump();
  mg_printf(conn,
            "HTTP/1.1 %d %s\r\nContent-Type: application/json\r\nContent-Length: %zu\r\n"
            "Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n%s\r\n",
            status, reason_phrase(status), text.size(), extra_headers.c_str());
  mg_write(conn, text.data(), text.size());
}

void send_error(mg_connection* conn, int status, const std::string& error) {
  send_json(conn, status, {{"ok", false}, {"error", error}});
}

std::string header(const mg_connection* conn, const char* name) {
  const char* value = mg_get_header(conn, name);
  return value == nullptr ? std::string() : std::string(value);
}

std::string session_token(const mg_connection* conn) {
  const char* cookies = mg_get_header(conn, "Cookie");
  if (cookies == nullptr) return {};
  std::array<char, 128> token{};
  const int length = mg_get_cookie(cookies, kSessionCookie, token.data(), token.size());
  return length > 0 ? std::string(token.data(), static_cast<std::size_t>(length)) : std::string();
}

// A browser names the page's origin on every POST and WebSocket upgrade: one from another
// site (a page that tries to drive the line through the operator's browser) does not match
// the Host it sent the request to. Clients that send no Origin (curl, tests) still need a
// session for any command.
bool same_origin(const mg_connection* conn) {
  const std::string origin = header(conn, "Origin");
  if (origin.empty()) return true;
  const std::string host = header(conn, "Host");
  return origin == "http://" + host || origin == "https://" + host;
}

std::optional<std::string> read_body(mg_connection* conn) {
  const mg_request_info* info = mg_get_request_info(conn);
  if (info->content_length < 0 || info->content_length > static_cast<long long>(kMaxBodyBytes)) {
    return std::nullopt;
  }
  std::string body(static_cast<std::size_t>(info->content_length), '\0');
  std::size_t read = 0;
  while (read < body.size()) {
    const int n = mg_read(conn, body.data() + read, body.size() - read);
    if (n <= 0) return std::nullopt;
    read += static_cast<std::size_t>(n);
  }
  return body;
}

struct Client {
  mg_connection* conn = nullptr;
  std::string token;  // the session cookie at the upgrade; empty when not logged in
  bool ready = false;
};

}  // namespace

struct HmiServer::Impl {
  HmiConfig config;
  TripleBuffer<LineStatus>& status;
  std::string layout_text;
  HmiCommands commands;
  ClockNs clock;
  SessionStore sessions;
  LoginThrottle throttle;

  mg_context* context = nullptr;
  int bound_port = 0;

  std::mutex clients_mutex;  // also held while writing to the clients, see close handler
  std::vector<Client*> clients;

  std::mutex latest_mutex;
  std::string latest_status_text;  // for GET /api/status and new WebSocket clients

  std::jthread broadcaster;

  Impl(HmiConfig config_in, TripleBuffer<LineStatus>& status_in, const nlohmann::json& layout,
       HmiCommands commands_in, ClockNs clock_in)
      : config(std::move(config_in)),
        status(status_in),
        layout_text(layout.dump()),
        commands(std::move(commands_in)),
        clock(clock_in ? std::move(clock_in) : ClockNs(steady_now_ns)),
        sessions(static_cast<std::int64_t>(config.session_idle_timeout_s * 1e9)),
        throttle(config.login_max_failures, kLoginWindowNs,
                 static_cast<std::int64_t>(config.login_lockout_s * 1e9)) {}

  // ------------------------------------------------------------ commands

  // Runs one operator command for a session's user; returns an error text or empty.
  std::string run_command(const std::string& user, const nlohmann::json& request) {
    const auto command = request.find("command");
    if (command == request.end() || !command->is_string()) {
      return "missing \"command\" (start, stop, acknowledge)";
    }
    const std::string name = command->get<std::string>();
    if (name == "start") {
      commands.start_line();
    } else if (name == "stop") {
      commands.stop_line();
    } else if (name == "acknowledge") {
      commands.acknowledge_faults();
    } else {
      return "unknown command '" + name + "' (start, stop, acknowledge)";
    }
    spdlog::info("hmi: {} by {}", name, user);
    return {};
  }

  std::string run_twin_fault(const std::string& user, const nlohmann::json& request) {
    if (!commands.twin_fault) return "no twin runs behind this controller";
    const auto fault = request.find("fault");
    const auto target = request.find("target");
    const auto active = request.find("active");
    if (fault == request.end() || !fault->is_string() || active == request.end() ||
        !active->is_boolean() || (target != request.end() && !target->is_string())) {
      return R"(expected {"fault": NAME, "target": NAME (optional), "active": true|false})";
    }
    const std::string target_name = target == request.end() ? "" : target->get<std::string>();
    std::string error =
        commands.twin_fault(fault->get<std::string>(), target_name, active->get<bool>());
    if (error.empty()) {
      spdlog::warn("hmi: twin fault {} {} {} by {}", fault->get<std::string>(), target_name,
                   active->get<bool>() ? "raised" : "cleared", user);
    }
    return error;
  }

  // ------------------------------------------------------------ HTTP

  int handle_api(mg_connection* conn) {
    try {
      return serve_api(conn);
    } catch (const std::exception& error) {
      spdlog::error("hmi: {} failed: {}", mg_get_request_info(conn)->local_uri, error.what());
      send_error(conn, 500, "internal error");
      return 500;
    }
  }

  int serve_api(mg_connection* conn) {
    const mg_request_info* info = mg_get_request_info(conn);
    const std::string method = info->request_method;
    const std::string uri = info->local_uri;
    if (method == "GET") {
      if (uri == "/api/status") {
        std::string text;
        {
          const std::lock_guard lock(latest_mutex);
          text = latest_status_text;
        }
        if (text.empty()) {
          send_error(conn, 503, "no status yet");
        } else {
          send_json(conn, 200, nlohmann::json::parse(text));
        }
      } else if (uri == "/api/layout") {
        send_json(conn, 200, nlohmann::json::parse(layout_text));
      } else if (uri == "/api/session") {
        const auto user = sessions.validate(session_token(conn), clock());
        send_json(conn, 200,
                  {{"authenticated", user.has_value()},
                   {"user", user ? nlohmann::json(*user) : nlohmann::json()},
                   {"logins_enabled", !config.operator_password_hash.empty()},
                   {"twin", static_cast<bool>(commands.twin_fault)}});
      } else {
        send_error(conn, 404, "no such resource");
      }
      return 200;
    }
    if (method != "POST") {
      send_error(conn, 405, "GET or POST only");
      return 405;
    }
    if (!same_origin(conn)) {
      send_error(conn, 403, "cross-origin request refused");
      return 403;
    }
    // A JSON content type cannot be sent cross-site without a CORS preflight, which this
    // server never grants.
    if (header(conn, "Content-Type").rfind("application/json", 0) != 0) {
      send_error(conn, 415, "Content-Type must be application/json");
      return 415;
    }
    const std::optional<std::string> body = read_body(conn);
    if (!body) {
      send_error(conn, 413, "body missing or over 4 KiB");
      return 413;
    }
    nlohmann::json request = nlohmann::json::parse(*body, nullptr, false);
    if (request.is_discarded() || !request.is_object()) {
      send_error(conn, 400, "body is not a JSON object");
      return 400;
    }
    if (uri == "/api/login") return handle_login(conn, request, info->remote_addr);
    if (uri == "/api/logout") {
      sessions.revoke(session_token(conn));
      send_json(conn, 200, {{"ok", true}},
                std::string("Set-Cookie: ") + kSessionCookie +
                    "=; Path=/; HttpOnly; SameSite=Strict; Max-Age=0\r\n");
      return 200;
    }
    if (uri != "/api/command" && uri != "/api/twin/fault") {
      send_error(conn, 404, "no such resource");
      return 404;
    }
    const auto user = sessions.validate(session_token(conn), clock());
    if (!user) {
      spdlog::warn("hmi: {} from {} refused: not logged in", uri, info->remote_addr);
      send_error(conn, 401, "log in first");
      return 401;
    }
    const std::string error =
        uri == "/api/command" ? run_command(*user, request) : run_twin_fault(*user, request);
    if (!error.empty()) {
      send_error(conn, 400, error);
      return 400;
    }
    send_json(conn, 200, {{"ok", true}});
    return 200;
  }

  int handle_login(mg_connection* conn, const nlohmann::json& request, const std::string& address) {
    const std::int64_t now_ns = clock();
    if (config.operator_password_hash.empty()) {
      send_error(conn, 403, "logins are disabled: set operator.password_hash in the HMI config");
      return 403;
    }
    if (!throttle.allowed(address, now_ns)) {
      send_error(conn, 429, "too many failed logins: wait and try again");
      return 429;
    }
    const auto user = request.find("user");
    const auto password = request.find("password");
    if (user == request.end() || !user->is_string() || password == request.end() ||
        !password->is_string()) {
      send_error(conn, 400, R"(expected {"user": ..., "password": ...})");
      return 400;
    }
    // The hash runs whatever the user name, so the answer time does not tell a wrong name
    // from a wrong password.
    const bool password_ok =
        verify_password(password->get<std::string>(), config.operator_password_hash);
    const bool user_ok = constant_time_equal(user->get<std::string>(), config.operator_user);
    if (!password_ok || !user_ok) {
      throttle.record_failure(address, now_ns);
      spdlog::warn("hmi: failed login from {}", address);
      send_error(conn, 401, "wrong user or password");
      return 401;
    }
    throttle.record_success(address);
    const std::string token = sessions.create(config.operator_user, now_ns);
    spdlog::info("hmi: {} logged in from {}", config.operator_user, address);
    send_json(conn, 200, {{"ok", true}, {"user", config.operator_user}},
              std::string("Set-Cookie: ") + kSessionCookie + "=" + token +
                  "; Path=/; HttpOnly; SameSite=Strict; Max-Age=" +
                  std::to_string(static_cast<long long>(config.session_idle_timeout_s)) + "\r\n");
    return 200;
  }

  // ------------------------------------------------------------ WebSocket

  int ws_connect(const mg_connection* conn) {
    try {
      return accept_ws(conn);
    } catch (const std::exception& error) {
      spdlog::error("hmi: WebSocket upgrade failed: {}", error.what());
      return 1;
    }
  }

  int accept_ws(const mg_connection* conn) {
    if (!same_origin(conn)) {
      spdlog::warn("hmi: cross-origin WebSocket from {} refused", header(conn, "Origin"));
      return 1;  // refuse the upgrade
    }
    auto* client = new Client{const_cast<mg_connection*>(conn), session_token(conn), false};
    mg_set_user_connection_data(conn, client);
    return 0;
  }

  void ws_ready(mg_connection* conn) {
    try {
      greet_ws(conn);
    } catch (const std::exception& error) {
      spdlog::error("hmi: WebSocket greeting failed: {}", error.what());
    }
  }

  void greet_ws(mg_connection* conn) {
    auto* client = static_cast<Client*>(mg_get_user_connection_data(conn));
    const auto user = sessions.validate(client->token, clock());
    const std::string hello = nlohmann::json{{"type", "hello"},
                                             {"authenticated", user.has_value()},
                                             {"user", user ? nlohmann::json(*user) : nullptr},
                                             {"twin", static_cast<bool>(commands.twin_fault)}}
                                  .dump();
    mg_websocket_write(conn, MG_WEBSOCKET_OPCODE_TEXT, hello.data(), hello.size());
    mg_websocket_write(conn, MG_WEBSOCKET_OPCODE_TEXT, layout_text.data(), layout_text.size());
    const std::lock_guard lock(clients_mutex);
    client->ready = true;
    clients.push_back(client);
  }

  int ws_data(mg_connection* conn, int opcode, const char* data, std::size_t length) {
    try {
      return answer_ws(conn, opcode, data, length);
    } catch (const std::exception& error) {
      spdlog::error("hmi: WebSocket message failed: {}", error.what());
      return 0;  // close this connection; the page reconnects
    }
  }

  int answer_ws(mg_connection* conn, int opcode, const char* data, std::size_t length) {
    const int kind = opcode & 0xF;
    if (kind == MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE) return 0;
    if (kind != MG_WEBSOCKET_OPCODE_TEXT) return 1;  // pings are answered by civetweb
    auto* client = static_cast<Client*>(mg_get_user_connection_data(conn));
    nlohmann::json reply = {{"type", "command_result"}, {"ok", false}};
    const nlohmann::json request = length > kMaxBodyBytes
                                       ? nlohmann::json()
                                       : nlohmann::json::parse(data, data + length, nullptr, false);
    if (!request.is_object()) {
      reply["error"] = "message is not a JSON object under 4 KiB";
    } else {
      if (request.contains("id")) reply["id"] = request["id"];
      const std::string type = request.value("type", "");
      const auto user = sessions.validate(client->token, clock());
      if (!user) {
        spdlog::warn("hmi: WebSocket {} refused: not logged in", type);
        reply["error"] = "log in first";
      } else if (type == "command" || type == "twin_fault") {
        const std::string error =
            type == "command" ? run_command(*user, request) : run_twin_fault(*user, request);
        reply["ok"] = error.empty();
        if (!error.empty()) reply["error"] = error;
      } else {
        reply["error"] = "unknown message type '" + type + "' (command, twin_fault)";
      }
    }
    const std::string text = reply.dump();
    mg_websocket_write(conn, MG_WEBSOCKET_OPCODE_TEXT, text.data(), text.size());
    return 1;
  }

  void ws_close(const mg_connection* conn) {
    auto* client = static_cast<Client*>(mg_get_user_connection_data(conn));
    if (client == nullptr) return;
    {
      const std::lock_guard lock(clients_mutex);
      std::erase(clients, client);
    }
    delete client;
  }

  // ------------------------------------------------------------ broadcaster

  void broadcast_loop(const std::stop_token& stop) {
    const auto period = std::chrono::duration<double>(1.0 / config.publish_rate_hz);
    ThroughputMeter throughput;
    auto next = std::chrono::steady_clock::now();
    while (!stop.stop_requested()) {
      next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
      std::this_thread::sleep_until(next);
      if (!status.take()) continue;  // no scan since the last push: the loop is not running
      const LineStatus& snapshot = status.front();
      throughput.add(snapshot.time_ns,
                     snapshot.counters.outcomes[static_cast<std::size_t>(Outcome::kPlaced)]);
      const std::string text = status_to_json(snapshot, throughput.placed_per_minute()).dump();
      {
        const std::lock_guard lock(latest_mutex);
        latest_status_text = text;
      }
      const std::lock_guard lock(clients_mutex);
      for (Client* client : clients) {
        mg_websocket_write(client->conn, MG_WEBSOCKET_OPCODE_TEXT, text.data(), text.size());
      }
    }
  }
};

HmiServer::HmiServer(HmiConfig config, TripleBuffer<LineStatus>& status,
                     const nlohmann::json& layout, HmiCommands commands, ClockNs clock)
    : impl_(std::make_unique<Impl>(std::move(config), status, layout, std::move(commands),
                                   std::move(clock))) {
  if (!impl_->commands.start_line || !impl_->commands.stop_line ||
      !impl_->commands.acknowledge_faults) {
    throw std::invalid_argument("HmiServer: start, stop and acknowledge commands are required");
  }
}

HmiServer::~HmiServer() { stop(); }

void HmiServer::start() {
  if (impl_->context != nullptr) throw std::logic_error("HmiServer::start: already started");
  static std::once_flag library_init;
  std::call_once(library_init, [] { mg_init_library(MG_FEATURES_WEBSOCKET); });

  const std::string document_root = impl_->config.document_root.empty()
                                        ? default_document_root().string()
                                        : impl_->config.document_root;
  const std::string ports = impl_->config.bind_address + ":" + std::to_string(impl_->config.port);
  const std::string threads = std::to_string(impl_->config.worker_threads);
  const std::array<const char*, 17> options = {
      "listening_ports", ports.c_str(), "document_root", document_root.c_str(), "num_threads",
      threads.c_str(), "enable_directory_listing", "no", "websocket_timeout_ms", "30000",
      "enable_websocket_ping_pong", "yes",
      // The page loads nothing from elsewhere and must not be framed by another site.
      "additional_header", "Content-Security-Policy: default-src 'self'; frame-ancestors 'none'",
      "request_timeout_ms", "10000", nullptr};

  mg_callbacks callbacks{};
  callbacks.log_message = [](const mg_connection*, const char* message) {
    spdlog::warn("hmi server: {}", message);
    return 1;
  };
  mg_init_data init{};
  init.callbacks = &callbacks;
  init.user_data = impl_.get();
  init.configuration_options = const_cast<const char**>(options.data());
  std::array<char, 256> error_text{};
  unsigned error_code = 0;
  mg_error_data error{};
  error.code = &error_code;
  error.text = error_text.data();
  error.text_buffer_size = error_text.size();
  impl_->context = mg_start2(&init, &error);
  if (impl_->context == nullptr) {
    throw std::runtime_error("HMI server on " + ports + " did not start: " + error_text.data());
  }

  mg_set_request_handler(
      impl_->context, "/api/",
      [](mg_connection* conn, void* self) { return static_cast<Impl*>(self)->handle_api(conn); },
      impl_.get());
  mg_set_websocket_handler(
      impl_->context, "/ws",
      [](const mg_connection* conn, void* self) {
        return static_cast<Impl*>(self)->ws_connect(conn);
      },
      [](mg_connection* conn, void* self) { static_cast<Impl*>(self)->ws_ready(conn); },
      [](mg_connection* conn, int opcode, char* data, std::size_t length, void* self) {
        return static_cast<Impl*>(self)->ws_data(conn, opcode, data, length);
      },
      [](const mg_connection* conn, void* self) { static_cast<Impl*>(self)->ws_close(conn); },
      impl_.get());

  std::array<mg_server_port, 4> bound{};
  const int count =
      mg_get_server_ports(impl_->context, static_cast<int>(bound.size()), bound.data());
  impl_->bound_port = count > 0 ? bound[0].port : 0;
  impl_->broadcaster = std::jthread(
      [impl = impl_.get()](const std::stop_token& stop) { impl->broadcast_loop(stop); });
  spdlog::info("hmi: http://{}:{}/ ({}; page from {})", impl_->config.bind_address,
               impl_->bound_port,
               impl_->config.operator_password_hash.empty()
                   ? "read-only: no operator.password_hash configured"
                   : "operator " + impl_->config.operator_user,
               document_root);
}

void HmiServer::stop() {
  if (impl_->broadcaster.joinable()) {
    impl_->broadcaster.request_stop();
    impl_->broadcaster.join();
  }
  if (impl_->context != nullptr) {
    mg_stop(impl_->context);  // closes every connection (close handlers run) and joins
    impl_->context = nullptr;
  }
}

int HmiServer::port() const { return impl_->bound_port; }

}  // namespace fl::hmi

// civetweb creates its worker threads with a fixed stack (CIVETWEB_THREAD_STACK_SIZE, 100 KB
// in Debian's build), and glibc carves each thread's static thread-local storage out of that
// stack. In linectl, OpenBLAS (pulled in through OpenCV) alone has 60 KB of it, so civetweb's
// own request path overflowed the rest and crashed. civetweb 1.15 has no option for the
// stack size, so this process raises any smaller request to kMinThreadStackBytes and
// forwards to libc's. libcivetweb asks for the versioned symbol
// pthread_attr_setstacksize@GLIBC_2.34, which an unversioned definition in the executable
// does not satisfy (the loader binds it to libc's): the definition carries that version
// (stack_size.map, linked into every executable that links fl_hmi).
namespace {
constexpr std::size_t kMinThreadStackBytes = std::size_t{1} << 20;
}

extern "C" int fl_hmi_pthread_attr_setstacksize(pthread_attr_t* attributes,
                                                std::size_t stack_bytes) {
  using SetStackSize = int (*)(pthread_attr_t*, std::size_t);
  static const auto libc_setstacksize =
      reinterpret_cast<SetStackSize>(dlvsym(RTLD_NEXT, "pthread_attr_setstacksize", "GLIBC_2.34"));
  if (libc_setstacksize == nullptr) return ENOSYS;
  return libc_setstacksize(attributes, std::max(stack_bytes, kMinThreadStackBytes));
}
__asm__(".symver fl_hmi_pthread_attr_setstacksize,pthread_attr_setstacksize@@GLIBC_2.34");

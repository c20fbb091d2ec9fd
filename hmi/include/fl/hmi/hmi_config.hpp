// The HMI server's configuration (config/hmi.yaml): where it listens, the operator's
// credentials and the session and update timing. Plain data filled by the strict loader.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace fl::hmi {

struct HmiConfig {
  std::string bind_address = "127.0.0.1";  // 0.0.0.0: every interface of the line PC
  std::uint16_t port = 8080;               // 0: any free port (tests)
  // Folder with index.html, app.js, style.css; empty: the page shipped with the build.
  std::string document_root;
  double publish_rate_hz = 10.0;        // status updates pushed to each browser
  double session_idle_timeout_s = 900;  // a login ends after this long without a command
  int worker_threads = 8;               // each open browser tab holds one (WebSocket)
  std::string operator_user = "operator";
  // pbkdf2-sha256$... from `linectl hmi hash-password`; empty: nobody can log in, the screen
  // is read-only.
  std::string operator_password_hash;
  int login_max_failures = 5;   // failed logins from one address within a minute ...
  double login_lockout_s = 30;  // ... lock that address out this long
};

// Throws fl::ConfigError naming file, key and line for every problem.
HmiConfig load_hmi_config(const std::filesystem::path& file);

// The page's folder in the source tree (a build), else the installed one.
std::filesystem::path default_document_root();

}  // namespace fl::hmi

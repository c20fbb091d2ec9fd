#include "fl/hmi/hmi_config.hpp"

#include <arpa/inet.h>

#include "fl/controller/yaml_reader.hpp"
#include "fl/hmi/auth.hpp"

namespace fl::hmi {

HmiConfig load_hmi_config(const std::filesystem::path& file) {
  YamlReader reader = YamlReader::from_file(file);
  HmiConfig config;
  {
    YamlMapReader root = reader.root();
    config.bind_address = root.read_string("bind_address");
    config.port = root.read_int<std::uint16_t>("port", Range::closed(0, 65535));
    config.document_root = root.read_string_or("document_root", "");
    config.publish_rate_hz =
        root.read_double_or("publish_rate_hz", config.publish_rate_hz, Range::closed(0.5, 50.0));
    config.session_idle_timeout_s = root.read_double_or(
        "session_idle_timeout_s", config.session_idle_timeout_s, Range::closed(1.0, 86400.0));
    config.worker_threads =
        root.read_int_or<int>("worker_threads", config.worker_threads, Range::closed(2, 64));
    {
      YamlMapReader login = root.map("operator");
      config.operator_user = login.read_string("user");
      config.operator_password_hash = login.read_string("password_hash");
      config.login_max_failures =
          login.read_int_or<int>("max_failures", config.login_max_failures, Range::closed(1, 100));
      config.login_lockout_s =
          login.read_double_or("lockout_s", config.login_lockout_s, Range::closed(0.0, 3600.0));
      login.finish();
      if (reader.all_read_ok({"operator.user"}) && config.operator_user.empty()) {
        reader.report_at("operator.user", ProblemKind::kInvalidValue, "must not be empty");
      }
      if (reader.all_read_ok({"operator.password_hash"}) &&
          !config.operator_password_hash.empty()) {
        const std::string problem = check_password_hash(config.operator_password_hash);
        if (!problem.empty()) {
          reader.report_at("operator.password_hash", ProblemKind::kInvalidValue, problem);
        }
      }
    }
    root.finish();
  }
  if (reader.all_read_ok({"bind_address"})) {
    in_addr parsed{};
    if (inet_pton(AF_INET, config.bind_address.c_str(), &parsed) != 1) {
      reader.report_at("bind_address", ProblemKind::kInvalidValue,
                       "'" + config.bind_address +
                           "' is not an IPv4 address (127.0.0.1: this PC only, 0.0.0.0: all)");
    }
  }
  if (reader.all_read_ok({"document_root"}) && !config.document_root.empty() &&
      !std::filesystem::is_regular_file(std::filesystem::path(config.document_root) /
                                        "index.html")) {
    reader.report_at("document_root", ProblemKind::kInvalidValue,
                     "'" + config.document_root + "' holds no index.html");
  }
  reader.throw_if_problems();
  return config;
}

std::filesystem::path default_document_root() {
  std::filesystem::path source = FL_HMI_SOURCE_WWW;
  if (std::filesystem::is_regular_file(source / "index.html")) return source;
  return FL_HMI_INSTALLED_WWW;
}

}  // namespace fl::hmi

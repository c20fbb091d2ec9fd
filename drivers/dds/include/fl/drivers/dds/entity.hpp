// RAII over Cyclone DDS's C API: every entity handle, QoS object and listener is owned by
// exactly one C++ object and deleted with it, and every failed call throws DdsError with
// the call and Cyclone's return code. Construction and destruction are outside the scan
// cycle (they allocate and lock inside Cyclone); only the objects built on top
// (DdsCameraInput, DdsLineOutput) offer real-time entry points.
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

namespace fl::drivers::dds {

class DdsError : public std::runtime_error {
 public:
  DdsError(const std::string& what, dds_return_t code);
  [[nodiscard]] dds_return_t code() const noexcept { return code_; }

 private:
  dds_return_t code_;
};

// Throws DdsError("<what>: <Cyclone's message>") when result < 0, returns it otherwise.
dds_return_t check(dds_return_t result, const char* what);

// One owned entity handle (domain, participant, topic, reader, writer). Deleting a parent
// deletes its children in Cyclone; deleting a child that is already gone is harmless.
class Entity {
 public:
  Entity() = default;
  Entity(dds_entity_t handle, const char* what) : handle_(check(handle, what)) {}
  ~Entity() { reset(); }
  Entity(Entity&& other) noexcept : handle_(other.release()) {}
  Entity& operator=(Entity&& other) noexcept;
  Entity(const Entity&) = delete;
  Entity& operator=(const Entity&) = delete;

  [[nodiscard]] dds_entity_t get() const noexcept { return handle_; }
  [[nodiscard]] explicit operator bool() const noexcept { return handle_ > 0; }
  void reset() noexcept;
  dds_entity_t release() noexcept;

 private:
  dds_entity_t handle_ = 0;
};

struct QosDeleter {
  void operator()(dds_qos_t* qos) const noexcept { dds_delete_qos(qos); }
};
using Qos = std::unique_ptr<dds_qos_t, QosDeleter>;
Qos make_qos();

struct ListenerDeleter {
  void operator()(dds_listener_t* listener) const noexcept { dds_delete_listener(listener); }
};
using Listener = std::unique_ptr<dds_listener_t, ListenerDeleter>;
Listener make_listener(void* arg);

// A domain with an explicit configuration (XML text or a file:// URI), instead of the
// process-wide CYCLONEDDS_URI. Tests use it to run a secured and a plain domain in one
// process; a domain id can exist once per process.
class Domain {
 public:
  Domain(dds_domainid_t id, const std::string& config);
  [[nodiscard]] dds_domainid_t id() const noexcept { return id_; }

 private:
  dds_domainid_t id_;
  Entity entity_;
};

class Participant {
 public:
  // DDS_DOMAIN_DEFAULT: the domain id of CYCLONEDDS_URI's configuration (0 by default).
  explicit Participant(dds_domainid_t domain = DDS_DOMAIN_DEFAULT);
  [[nodiscard]] dds_entity_t get() const noexcept { return entity_.get(); }

 private:
  Entity entity_;
};

class Topic {
 public:
  Topic(const Participant& participant, const dds_topic_descriptor_t& type, const char* name);
  [[nodiscard]] dds_entity_t get() const noexcept { return entity_.get(); }

 private:
  Entity entity_;
};

class Writer {
 public:
  Writer(const Participant& participant, const Topic& topic, const dds_qos_t* qos,
         const dds_listener_t* listener = nullptr);
  [[nodiscard]] dds_entity_t get() const noexcept { return entity_.get(); }

  // Serialises and sends; the return code is Cyclone's (negative: failed). Allocates and
  // locks inside Cyclone: not for the scan thread.
  template <class Sample>
  dds_return_t write(const Sample& sample) const noexcept {
    return dds_write(entity_.get(), &sample);
  }
  // Publications matched now (readers that accepted this writer's QoS).
  [[nodiscard]] std::uint32_t matched_readers() const;

 private:
  Entity entity_;
};

class Reader {
 public:
  Reader(const Participant& participant, const Topic& topic, const dds_qos_t* qos,
         const dds_listener_t* listener = nullptr);
  [[nodiscard]] dds_entity_t get() const noexcept { return entity_.get(); }
  [[nodiscard]] std::uint32_t matched_writers() const;

 private:
  Entity entity_;
};

}  // namespace fl::drivers::dds

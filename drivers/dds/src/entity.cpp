#include "fl/drivers/dds/entity.hpp"

#include <utility>

namespace fl::drivers::dds {

DdsError::DdsError(const std::string& what, dds_return_t code)
    : std::runtime_error(what + ": " + dds_strretcode(code)), code_(code) {}

dds_return_t check(dds_return_t result, const char* what) {
  if (result < 0) throw DdsError(what, result);
  return result;
}

Entity& Entity::operator=(Entity&& other) noexcept {
  if (this != &other) {
    reset();
    handle_ = other.release();
  }
  return *this;
}

void Entity::reset() noexcept {
  // The result is ignored on purpose: a child whose parent was deleted first is already
  // gone (DDS_RETCODE_BAD_PARAMETER), which is what we wanted.
  if (handle_ > 0) (void)dds_delete(handle_);
  handle_ = 0;
}

dds_entity_t Entity::release() noexcept { return std::exchange(handle_, 0); }

Qos make_qos() {
  Qos qos(dds_create_qos());
  if (!qos) throw DdsError("dds_create_qos", DDS_RETCODE_OUT_OF_RESOURCES);
  return qos;
}

Listener make_listener(void* arg) {
  Listener listener(dds_create_listener(arg));
  if (!listener) throw DdsError("dds_create_listener", DDS_RETCODE_OUT_OF_RESOURCES);
  return listener;
}

Domain::Domain(dds_domainid_t id, const std::string& config)
    : id_(id), entity_(dds_create_domain(id, config.c_str()), "dds_create_domain") {}

Participant::Participant(dds_domainid_t domain)
    : entity_(dds_create_participant(domain, nullptr, nullptr), "dds_create_participant") {}

Topic::Topic(const Participant& participant, const dds_topic_descriptor_t& type, const char* name)
    : entity_(dds_create_topic(participant.get(), &type, name, nullptr, nullptr),
              "dds_create_topic") {}

Writer::Writer(const Participant& participant, const Topic& topic, const dds_qos_t* qos,
               const dds_listener_t* listener)
    : entity_(dds_create_writer(participant.get(), topic.get(), qos, listener),
              "dds_create_writer") {}

std::uint32_t Writer::matched_readers() const {
  dds_publication_matched_status_t status{};
  check(dds_get_publication_matched_status(entity_.get(), &status),
        "dds_get_publication_matched_status");
  return status.current_count;
}

Reader::Reader(const Participant& participant, const Topic& topic, const dds_qos_t* qos,
               const dds_listener_t* listener)
    : entity_(dds_create_reader(participant.get(), topic.get(), qos, listener),
              "dds_create_reader") {}

std::uint32_t Reader::matched_writers() const {
  dds_subscription_matched_status_t status{};
  check(dds_get_subscription_matched_status(entity_.get(), &status),
        "dds_get_subscription_matched_status");
  return status.current_count;
}

}  // namespace fl::drivers::dds

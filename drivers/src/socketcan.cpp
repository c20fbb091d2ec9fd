#include "fl/drivers/socketcan.hpp"

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

namespace fl::drivers {
namespace {

[[noreturn]] void fail(const std::string& interface_name, const char* call) {
  throw SocketCanError("SocketCAN " + interface_name + ": " + call +
                       " failed: " + std::strerror(errno));
}

std::int64_t clock_ns(clockid_t clock) {
  timespec now{};
  clock_gettime(clock, &now);
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

// Control buffer for one message: the timestamp and the drop counter.
constexpr std::size_t kControlBytes =
    CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t));

}  // namespace

SocketCanBus::SocketCanBus(const SocketCanOptions& options)
    : interface_name_(options.interface_name), confirm_sends_(options.confirm_sends) {
  if (interface_name_.empty() || interface_name_.size() >= IFNAMSIZ) {
    throw SocketCanError("SocketCAN: interface name '" + interface_name_ + "' must have 1.." +
                         std::to_string(IFNAMSIZ - 1) + " characters");
  }
  socket_fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (socket_fd_ < 0) {
    fail(interface_name_, "socket(PF_CAN, SOCK_RAW, CAN_RAW) (is the can-raw module loaded?)");
  }
  try {
    ifreq request{};
    std::memcpy(request.ifr_name, interface_name_.c_str(), interface_name_.size() + 1);
    if (::ioctl(socket_fd_, SIOCGIFINDEX, &request) < 0) {
      fail(interface_name_, "ioctl(SIOCGIFINDEX) (does the interface exist?)");
    }
    sockaddr_can address{};
    address.can_family = AF_CAN;
    address.can_ifindex = request.ifr_ifindex;

    // Filters before bind, so that no unwanted frame is queued in between.
    std::vector<can_filter> filters;
    for (const auto& [id, mask] : options.filters) {
      filters.push_back(can_filter{id, mask});
    }
    if (filters.empty()) {
      filters.push_back(can_filter{0, 0});  // {0, 0} receives all; length 0 would receive none
    }
    if (::setsockopt(socket_fd_, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                     static_cast<socklen_t>(filters.size() * sizeof(can_filter))) < 0) {
      fail(interface_name_, "setsockopt(CAN_RAW_FILTER)");
    }
    const can_err_mask_t error_mask = options.receive_error_frames ? CAN_ERR_MASK : 0;
    if (::setsockopt(socket_fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &error_mask, sizeof error_mask) <
        0) {
      fail(interface_name_, "setsockopt(CAN_RAW_ERR_FILTER)");
    }
    const int own = options.receive_own_frames || options.confirm_sends ? 1 : 0;
    if (::setsockopt(socket_fd_, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &own, sizeof own) < 0) {
      fail(interface_name_, "setsockopt(CAN_RAW_RECV_OWN_MSGS)");
    }
    const int one = 1;
    if (::setsockopt(socket_fd_, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one) < 0) {
      fail(interface_name_, "setsockopt(SO_TIMESTAMPNS)");
    }
    // The kernel reports how many frames it dropped for a full receive queue.
    if (::setsockopt(socket_fd_, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one) < 0) {
      fail(interface_name_, "setsockopt(SO_RXQ_OVFL)");
    }
    if (options.receive_buffer_bytes > 0 &&
        ::setsockopt(socket_fd_, SOL_SOCKET, SO_RCVBUF, &options.receive_buffer_bytes,
                     sizeof options.receive_buffer_bytes) < 0) {
      fail(interface_name_, "setsockopt(SO_RCVBUF)");
    }
    if (::bind(socket_fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) < 0) {
      fail(interface_name_, "bind");
    }
  } catch (...) {
    ::close(socket_fd_);
    throw;
  }
}

SocketCanBus::~SocketCanBus() {
  if (socket_fd_ >= 0) {
    ::close(socket_fd_);
  }
}

bool SocketCanBus::interface_running() const {
  ifreq request{};
  std::memcpy(request.ifr_name, interface_name_.c_str(), interface_name_.size() + 1);
  return ::ioctl(socket_fd_, SIOCGIFFLAGS, &request) == 0 && (request.ifr_flags & IFF_UP) != 0 &&
         (request.ifr_flags & IFF_RUNNING) != 0;
}

bool SocketCanBus::send(const CanFrame& frame) {
  if (error_state_ == CanErrorState::kBusOff) {
    // Off the bus until the kernel restarts the controller; should its restart frame have been
    // lost, the carrier tells.
    const std::int64_t now = clock_ns(CLOCK_MONOTONIC);
    const bool probe_due = now >= bus_off_probe_ns_;
    if (!probe_due || !interface_running()) {
      if (probe_due) bus_off_probe_ns_ = now + kBusOffProbeNs;
      ++counters_.tx_errors;
      return false;
    }
    error_state_ = CanErrorState::kErrorActive;
    ++counters_.restarts_inferred;
  }
  if (frame.dlc > kCanMaxDataBytes || frame.error) {
    ++counters_.malformed_frames;
    return false;
  }
  can_frame raw{};
  raw.can_id =
      frame.extended ? ((frame.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (frame.id & CAN_SFF_MASK);
  if (frame.remote) {
    raw.can_id |= CAN_RTR_FLAG;
  }
  raw.len = frame.dlc;
  std::memcpy(raw.data, frame.data.data(), frame.dlc);
  const std::int64_t queued_ns = confirm_sends_ ? clock_ns(CLOCK_MONOTONIC) : 0;
  const ssize_t written = ::send(socket_fd_, &raw, sizeof raw, MSG_DONTWAIT);
  if (written == static_cast<ssize_t>(sizeof raw)) {
    ++counters_.frames_sent;
    if (confirm_sends_) {
      confirmations_.record_send(frame, queued_ns, counters_);
    }
    return true;
  }
  // ENOBUFS: the interface's TX queue (txqueuelen) is full; EAGAIN: the socket send buffer
  // is. Both mean "the bus cannot keep up": count and drop, the next cycle sends fresh data.
  if (written < 0 && (errno == ENOBUFS || errno == EAGAIN || errno == EWOULDBLOCK)) {
    ++counters_.tx_queue_full;
  } else {
    ++counters_.tx_errors;
  }
  return false;
}

std::size_t SocketCanBus::receive(std::span<CanFrame> out) {
  std::size_t count = 0;
  // Kernel stamps are CLOCK_REALTIME; the controller's clock is CLOCK_MONOTONIC. The offset
  // is sampled once per call: only a wall-clock step during the call skews the stamps.
  const std::int64_t realtime_to_monotonic_ns =
      clock_ns(CLOCK_MONOTONIC) - clock_ns(CLOCK_REALTIME);
  while (count < out.size()) {
    can_frame raw{};
    iovec io{&raw, sizeof raw};
    alignas(cmsghdr) std::array<unsigned char, kControlBytes> control{};
    msghdr message{};
    message.msg_iov = &io;
    message.msg_iovlen = 1;
    message.msg_control = control.data();
    message.msg_controllen = control.size();
    const ssize_t received = ::recvmsg(socket_fd_, &message, MSG_DONTWAIT);
    if (received < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
        ++counters_.rx_errors;  // e.g. ENETDOWN while the interface is down
      }
      break;
    }
    if (received != static_cast<ssize_t>(sizeof raw) || raw.len > kCanMaxDataBytes) {
      ++counters_.malformed_frames;
      continue;
    }
    std::int64_t stamp_ns = 0;
    for (cmsghdr* header = CMSG_FIRSTHDR(&message); header != nullptr;
         header = CMSG_NXTHDR(&message, header)) {
      if (header->cmsg_level != SOL_SOCKET) {
        continue;
      }
      if (header->cmsg_type == SCM_TIMESTAMPNS) {
        timespec stamp{};
        std::memcpy(&stamp, CMSG_DATA(header), sizeof stamp);
        stamp_ns = static_cast<std::int64_t>(stamp.tv_sec) * 1'000'000'000 + stamp.tv_nsec +
                   realtime_to_monotonic_ns;
      } else if (header->cmsg_type == SO_RXQ_OVFL) {
        std::uint32_t dropped_total = 0;  // cumulative since the socket opened
        std::memcpy(&dropped_total, CMSG_DATA(header), sizeof dropped_total);
        if (dropped_total > counters_.rx_overruns) {
          counters_.rx_overruns = dropped_total;
        }
      }
    }
    if ((raw.can_id & CAN_ERR_FLAG) != 0U) {
      std::array<std::uint8_t, kCanMaxDataBytes> data{};
      std::memcpy(data.data(), raw.data, kCanMaxDataBytes);
      apply_error_frame(raw.can_id & CAN_ERR_MASK, data);
      continue;
    }
    CanFrame frame;
    frame.extended = (raw.can_id & CAN_EFF_FLAG) != 0U;
    frame.remote = (raw.can_id & CAN_RTR_FLAG) != 0U;
    frame.id = raw.can_id & (frame.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    frame.dlc = raw.len;
    std::memcpy(frame.data.data(), raw.data, raw.len);
    frame.timestamp_ns = stamp_ns != 0 ? stamp_ns : clock_ns(CLOCK_MONOTONIC);
    if (confirm_sends_ && (message.msg_flags & MSG_CONFIRM) != 0) {
      // An echo of this socket's own frame: its stamp is the send time. One without a record
      // (evicted, already counted as unconfirmed) is dropped.
      confirmations_.confirm(frame, frame.timestamp_ns, counters_);
      continue;
    }
    out[count] = frame;
    ++counters_.frames_received;
    ++count;
  }
  return count;
}

CanErrorState SocketCanBus::next_error_state(
    CanErrorState current, std::uint32_t class_bits,
    const std::array<std::uint8_t, kCanMaxDataBytes>& data) {
  if ((class_bits & CAN_ERR_BUSOFF) != 0U) {
    return CanErrorState::kBusOff;
  }
  if ((class_bits & CAN_ERR_RESTARTED) != 0U) {
    return CanErrorState::kErrorActive;
  }
  if ((class_bits & CAN_ERR_CRTL) != 0U) {
    const std::uint8_t controller = data[1];
    if ((controller & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0U) {
      return CanErrorState::kErrorPassive;
    }
    if ((controller & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0U) {
      return CanErrorState::kErrorWarning;
    }
    if ((controller & CAN_ERR_CRTL_ACTIVE) != 0U) {
      return CanErrorState::kErrorActive;
    }
  }
  return current;  // bus errors, lost arbitration, ACK errors: no state change by themselves
}

void SocketCanBus::apply_error_frame(std::uint32_t class_bits,
                                     const std::array<std::uint8_t, kCanMaxDataBytes>& data) {
  ++counters_.error_frames;
  if ((class_bits & CAN_ERR_CRTL) != 0U &&
      (data[1] & (CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW)) != 0U) {
    ++counters_.rx_overruns;  // the controller's own buffers overflowed
  }
  const CanErrorState next = next_error_state(error_state_, class_bits, data);
  if (next == CanErrorState::kBusOff && error_state_ != CanErrorState::kBusOff) {
    ++counters_.bus_off_events;
    // The carrier is asked only after a restart was due: can-dev may report bus off before it
    // drops the carrier.
    bus_off_probe_ns_ = clock_ns(CLOCK_MONOTONIC) + kBusOffProbeNs;
  }
  if ((class_bits & CAN_ERR_RESTARTED) != 0U) {
    ++counters_.restarts;
  }
  error_state_ = next;
}

}  // namespace fl::drivers

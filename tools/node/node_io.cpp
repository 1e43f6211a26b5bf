#include "node_io.h"

#include <pcl_ecs/io/cloud_io.h>

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <chrono>
#include <vector>
#include <cstring>
#include <sstream>

namespace pcl_ecs
{
namespace node
{

namespace
{
int parsePort(const std::string& s, const std::string& whole)
{
  char* end = nullptr;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || end != s.c_str() + s.size() || v < 1 || v > 65535)
    throw std::invalid_argument("'" + whole + "': port must be in [1, 65535]");
  return static_cast<int>(v);
}

}  // namespace

Endpoint parseEndpoint(const std::string& text, bool is_source)
{
  Endpoint e;
  if (text == (is_source ? "stdin" : "stdout"))
    return e;
  if (text.rfind("dir:", 0) == 0 && text.size() > 4)
  {
    e.kind = Endpoint::Kind::Dir;
    e.path = text.substr(4);
    return e;
  }
  if (!is_source && text.rfind("tcp-listen:", 0) == 0)
  {
    e.kind = Endpoint::Kind::TcpListen;
    e.port = parsePort(text.substr(11), text);
    return e;
  }
  if (text.rfind("tcp:", 0) == 0)
  {
    e.kind = Endpoint::Kind::Tcp;
    const std::string rest = text.substr(4);
    if (is_source)
      e.port = parsePort(rest, text);
    else
    {
      const auto colon = rest.rfind(':');
      if (colon == std::string::npos || colon == 0)
        throw std::invalid_argument("'" + text + "': a TCP sink is tcp:HOST:PORT");
      e.host = rest.substr(0, colon);
      e.port = parsePort(rest.substr(colon + 1), text);
    }
    return e;
  }
  throw std::invalid_argument("'" + text + "' is not " +
                              (is_source ? std::string("dir:PATH, tcp:PORT or stdin")
                                         : std::string("dir:PATH, tcp:HOST:PORT, tcp-listen:PORT or stdout")));
}

std::string serializeBinaryPcd(const pcl::PCLPointCloud2& c)
{
  std::ostringstream out;
  io::writePcd(out, c, io::Encoding::Binary);  // the writer of every tool: packed records
  return out.str();
}

ByteBudget::Reservation ByteBudget::acquire(std::uint64_t bytes, const volatile bool* stop)
{
  if (bytes > limit_)
    return {};
  std::unique_lock<std::mutex> lock(m_);
  // A stop comes from a signal handler, which notifies no one: look every 100 ms.
  while (used_ + bytes > limit_)
  {
    if (stop && *stop)
      return {};
    cv_.wait_for(lock, std::chrono::milliseconds(100));
  }
  used_ += bytes;
  return Reservation(this, bytes);
}

void ByteBudget::release(std::uint64_t bytes)
{
  std::lock_guard<std::mutex> lock(m_);
  used_ -= bytes;
  cv_.notify_all();
}

bool readExact(int fd, void* data, std::size_t n, const volatile bool* stop, int timeout_ms)
{
  auto* p = static_cast<std::uint8_t*>(data);
  std::size_t got = 0;
  using Clock = std::chrono::steady_clock;
  auto last_byte = Clock::now();
  while (got < n)
  {
    if (stop || timeout_ms >= 0)
    {
      pollfd pfd{fd, POLLIN, 0};
      const int r = ::poll(&pfd, 1, 100);
      if (r == 0)
      {
        if (stop && *stop && got == 0)
          return false;
        if (stop && *stop)
          throw StreamError("stopped in the middle of a frame");
        if (timeout_ms >= 0 && Clock::now() - last_byte >= std::chrono::milliseconds(timeout_ms))
        {
          char why[96];
          std::snprintf(why, sizeof(why), "no data for %g s in the middle of a frame (--read-timeout)", timeout_ms / 1000.0);
          throw StreamError(why);
        }
        continue;
      }
      if (r < 0 && errno == EINTR)
        continue;
    }
    const ssize_t r = ::read(fd, p + got, n - got);
    if (r == 0)
    {
      if (got == 0)
        return false;
      throw StreamError("the stream ended in the middle of a frame");
    }
    if (r < 0)
    {
      if (errno == EINTR || errno == EAGAIN)
        continue;
      throw StreamError(std::string("read error: ") + std::strerror(errno));
    }
    got += static_cast<std::size_t>(r);
    last_byte = Clock::now();
  }
  return true;
}

void writeAll(int fd, const void* data, std::size_t n, const volatile bool* stop)
{
  const auto* p = static_cast<const std::uint8_t*>(data);
  std::size_t put = 0;
  while (put < n)
  {
    if (stop)
    {
      pollfd pfd{fd, POLLOUT, 0};
      const int r = ::poll(&pfd, 1, *stop ? 0 : 100);
      if (r == 0)
      {
        if (*stop)
          throw StreamError("stopped while the consumer was not reading");
        continue;
      }
    }
    // With a stop to watch, never block inside send: a full buffer comes back to the poll above.
    const ssize_t w = ::send(fd, p + put, n - put, MSG_NOSIGNAL | (stop ? MSG_DONTWAIT : 0));
    if (w < 0 && errno == ENOTSOCK)
    {
      const ssize_t v = ::write(fd, p + put, n - put);
      if (v < 0)
      {
        if (errno == EINTR)
          continue;
        throw StreamError(std::string("write error: ") + std::strerror(errno));
      }
      put += static_cast<std::size_t>(v);
      continue;
    }
    if (w < 0)
    {
      if (errno == EINTR || (stop && (errno == EAGAIN || errno == EWOULDBLOCK)))
        continue;
      throw StreamError(std::string("write error: ") + std::strerror(errno));
    }
    put += static_cast<std::size_t>(w);
  }
}

bool readFrame(int fd, std::string& frame, const volatile bool* stop, const FrameLimits& limits,
               ByteBudget::Reservation* held)
{
  std::uint8_t len_bytes[8];
  // Between frames a producer may stay silent as long as it likes; the timeout starts with the
  // first byte of a frame.
  if (!readExact(fd, len_bytes, 1, stop))
    return false;
  if (!readExact(fd, len_bytes + 1, 7, stop, limits.timeout_ms))
    throw StreamError(stop && *stop ? "stopped in the middle of a frame" : "the stream ended in the middle of a frame");
  std::uint64_t len = 0;
  for (int i = 7; i >= 0; --i)
    len = (len << 8) | len_bytes[i];
  if (len > limits.max_bytes)
    throw StreamError("frame length " + std::to_string(len) + " exceeds --max-frame-bytes " +
                      std::to_string(limits.max_bytes));
  if (limits.budget && held)
  {
    *held = limits.budget->acquire(len, stop);
    if (held->bytes() != len && len > 0)
      throw StreamError("stopped while waiting for room for a frame");
  }
  // Filled chunk by chunk as the bytes arrive: a peer that announces a large frame and sends
  // nothing holds no memory for it. With a budget the length is reserved there, so the buffer is
  // reserved whole (address space; pages count only once written) instead of growing by copies.
  constexpr std::uint64_t kChunk = 1u << 20;
  frame.clear();
  if (limits.budget && held)
    frame.reserve(static_cast<std::size_t>(len));
  while (frame.size() < len)
  {
    const std::size_t at = frame.size();
    const auto chunk = static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, len - at));
    frame.resize(at + chunk);
    if (!readExact(fd, frame.data() + at, chunk, stop, limits.timeout_ms))
      throw StreamError(stop && *stop ? "stopped in the middle of a frame" : "the stream ended in the middle of a frame");
  }
  return true;
}

void writeFrame(int fd, const std::string& frame, const volatile bool* stop)
{
  std::uint8_t len_bytes[8];
  std::uint64_t len = frame.size();
  for (int i = 0; i < 8; ++i)
    len_bytes[i] = static_cast<std::uint8_t>(len >> (8 * i));
  writeAll(fd, len_bytes, 8, stop);
  writeAll(fd, frame.data(), frame.size(), stop);
}

int listenTcp(int port)
{
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0)
    throw StreamError(std::string("socket: ") + std::strerror(errno));
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 || ::listen(fd, SOMAXCONN) != 0)
  {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw StreamError("cannot listen on port " + std::to_string(port) + ": " + why);
  }
  return fd;
}

int acceptTcp(int listen_fd, int timeout_ms)
{
  pollfd pfd{listen_fd, POLLIN, 0};
  if (::poll(&pfd, 1, timeout_ms) <= 0)
    return -1;
  const int fd = ::accept(listen_fd, nullptr, nullptr);
  if (fd >= 0)
  {
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
  }
  return fd;
}

int connectTcp(const std::string& host, int port)
{
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  if (::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &res) != 0 || !res)
    return -1;
  const int fd = ::socket(res->ai_family, res->ai_socktype, res->ai_protocol);
  if (fd >= 0 && ::connect(fd, res->ai_addr, res->ai_addrlen) != 0)
  {
    ::close(fd);
    ::freeaddrinfo(res);
    return -1;
  }
  ::freeaddrinfo(res);
  if (fd >= 0)
  {
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
  }
  return fd;
}

}  // namespace node
}  // namespace pcl_ecs

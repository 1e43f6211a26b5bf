// node_io.h — the pieces of ecs_node that talk to the outside: endpoints, the frame format on TCP
// and pipes (8-byte little-endian length, then a complete PCD file), an in-memory binary PCD
// writer, and file-descriptor helpers. Documented for other programs in docs/NODE_PROTOCOL.md.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include <pcl/PCLPointCloud2.h>

namespace pcl_ecs
{
namespace node
{

/** \brief Where frames come from or go to. */
struct Endpoint
{
  enum class Kind
  {
    Dir,        ///< dir:PATH
    Tcp,        ///< tcp:PORT (source: listen) / tcp:HOST:PORT (sink: connect)
    TcpListen,  ///< tcp-listen:PORT (sink: accept one consumer at a time)
    Stdio       ///< stdin (source) / stdout (sink)
  };
  Kind kind = Kind::Stdio;
  std::string path, host;
  int port = 0;
};

/** \brief Parse "dir:PATH", "tcp:PORT", "tcp:HOST:PORT", "tcp-listen:PORT", "stdin", "stdout".
 * Throws std::invalid_argument naming what is wrong. */
Endpoint parseEndpoint(const std::string& text, bool is_source);

/** \brief A cloud as a complete binary PCD file in memory. */
std::string serializeBinaryPcd(const pcl::PCLPointCloud2& cloud);

/** \brief Default of --max-frame-bytes: the largest frame accepted, and the largest cloud a
 * frame may decode to (points × record size). */
constexpr std::uint64_t kDefaultMaxFrameBytes = 256ull << 20;

/** \brief Thrown when a stream breaks (closed mid-frame, oversize length, I/O error). */
struct StreamError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

/** \brief Read exactly n bytes; false on a clean end of stream, or a stop, before the first byte;
 * throws StreamError on an end or a stop in the middle. `stop` is polled every 100 ms while
 * waiting. */
bool readExact(int fd, void* data, std::size_t n, const volatile bool* stop = nullptr);
/** \brief Write all n bytes (handles partial writes); throws StreamError. With `stop`, a peer that
 * does not read is waited for in steps of 100 ms only until `stop` is set: then StreamError. */
void writeAll(int fd, const void* data, std::size_t n, const volatile bool* stop = nullptr);

/** \brief Read one frame; false at a clean end of stream. A length above `max_bytes` is a
 * StreamError; the frame's memory grows with the bytes that arrive, not with the length a peer
 * announces. */
bool readFrame(int fd, std::string& frame, const volatile bool* stop = nullptr,
               std::uint64_t max_bytes = kDefaultMaxFrameBytes);
/** \brief Write one frame (length prefix + bytes). */
void writeFrame(int fd, const std::string& frame, const volatile bool* stop = nullptr);

/** \brief A listening TCP socket on all interfaces (SO_REUSEADDR). Throws StreamError. */
int listenTcp(int port);
/** \brief Wait up to `timeout_ms` for a connection; -1 when none came. */
int acceptTcp(int listen_fd, int timeout_ms);
/** \brief Connect to host:port; -1 on failure. */
int connectTcp(const std::string& host, int port);

}  // namespace node
}  // namespace pcl_ecs

// node_io.h — the pieces of ecs_node that talk to the outside: endpoints, the frame format on TCP
// and pipes (8-byte little-endian length, then a complete PCD file), an in-memory binary PCD
// writer, and file-descriptor helpers. Documented for other programs in docs/NODE_PROTOCOL.md.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
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

/** \brief Default of --read-timeout: the longest a producer may send nothing in the middle of a
 * frame before the connection is dropped. */
constexpr int kDefaultReadTimeoutMs = 30000;

/** \brief A bound on the bytes all frames in flight hold together (read, queued or being
 * processed). A reader reserves a frame's announced length before it reads the frame, and waits
 * while the reservation would exceed the bound: the peer is then not read (TCP pushes back).
 * Whole-frame reservations cannot deadlock: every reserved frame can complete. */
class ByteBudget
{
public:
  explicit ByteBudget(std::uint64_t limit) : limit_(limit) {}

  /** \brief Bytes taken from a budget; given back when destroyed. Movable, not copyable. */
  class Reservation
  {
  public:
    Reservation() = default;
    Reservation(ByteBudget* budget, std::uint64_t bytes) : budget_(budget), bytes_(bytes) {}
    Reservation(Reservation&& o) noexcept : budget_(o.budget_), bytes_(o.bytes_) { o.budget_ = nullptr; }
    Reservation& operator=(Reservation&& o) noexcept
    {
      if (this != &o)
      {
        reset();
        budget_ = o.budget_;
        bytes_ = o.bytes_;
        o.budget_ = nullptr;
      }
      return *this;
    }
    Reservation(const Reservation&) = delete;
    Reservation& operator=(const Reservation&) = delete;
    ~Reservation() { reset(); }
    void reset()
    {
      if (budget_)
        budget_->release(bytes_);
      budget_ = nullptr;
    }
    std::uint64_t bytes() const { return budget_ ? bytes_ : 0; }

  private:
    ByteBudget* budget_ = nullptr;
    std::uint64_t bytes_ = 0;
  };

  /** \brief Wait until `bytes` fit, then take them. Empty (nothing taken) when `stop` became set
   * first, or when `bytes` exceeds the whole limit. `stop` is polled every 100 ms. */
  Reservation acquire(std::uint64_t bytes, const volatile bool* stop = nullptr);

private:
  void release(std::uint64_t bytes);
  std::uint64_t limit_, used_ = 0;
  std::mutex m_;
  std::condition_variable cv_;
};

/** \brief Read exactly n bytes; false on a clean end of stream, or a stop, before the first byte;
 * throws StreamError on an end or a stop in the middle. `stop` is polled every 100 ms while
 * waiting. With `timeout_ms` >= 0, a wait of that long for the next byte throws StreamError
 * (before the first byte too). */
bool readExact(int fd, void* data, std::size_t n, const volatile bool* stop = nullptr, int timeout_ms = -1);
/** \brief Write all n bytes (handles partial writes); throws StreamError. With `stop`, a peer that
 * does not read is waited for in steps of 100 ms only until `stop` is set: then StreamError. */
void writeAll(int fd, const void* data, std::size_t n, const volatile bool* stop = nullptr);

/** \brief What a reader allows a peer. */
struct FrameLimits
{
  std::uint64_t max_bytes = kDefaultMaxFrameBytes;  ///< longest frame; longer is a StreamError
  int timeout_ms = -1;             ///< in the middle of a frame, the longest wait for a byte (-1: none)
  ByteBudget* budget = nullptr;    ///< when set, the frame's length is reserved before it is read
};

/** \brief Read one frame; false at a clean end of stream (or a stop between frames). A length
 * above `limits.max_bytes`, a pause longer than `limits.timeout_ms` inside the frame, an end or a
 * stop inside it are StreamErrors. The frame's memory grows with the bytes that arrive, not with
 * the length a peer announces. With a budget, the frame's length is reserved into `held` first
 * (a stop while waiting for it is a StreamError). */
bool readFrame(int fd, std::string& frame, const volatile bool* stop = nullptr, const FrameLimits& limits = {},
               ByteBudget::Reservation* held = nullptr);
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

// ecs_node — a ROS-free streaming node: point cloud frames from a source (directory, TCP, stdin)
// are simplified by worker threads with the filter and handed to a sink (directory, TCP, stdout)
// in their original order. Configured by a launch file (YAML) and/or flags.
#include "common/cli.h"
#include "common/cloud_simplify.h"
#include "node/node_io.h"
#include "node/node_options.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/io/las_io.h>
#include <pcl_ecs/io/pcd_stream.h>
#include <pcl_ecs/version.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <list>
#include <map>
#include <sstream>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include <pcl/console/print.h>
#include <malloc.h>
#include <sys/stat.h>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace pcl_ecs;
using namespace pcl_ecs::node;
using Clock = std::chrono::steady_clock;

namespace
{

volatile bool g_stop = false;
void onSignal(int) { g_stop = true; }

struct Frame
{
  std::uint64_t seq = 0;
  std::string name;  // file name for a directory source, else empty
  std::string bytes;
  ByteBudget::Reservation held;  // the frame's share of --max-bytes-in-flight
  Clock::time_point arrived;
  std::string refused;  // set when the source already knows the frame is bad (never read)
};

struct Outcome
{
  bool ok = false;
  std::string name, bytes;
  Clock::time_point arrived;
  std::size_t points_in = 0, points_out = 0;
};

/// Counters and latencies, shared by every thread.
struct Stats
{
  std::atomic<std::uint64_t> in{0}, out{0}, dropped{0}, bad{0}, sink_errors{0}, points_in{0}, points_out{0};
  std::mutex m;
  std::deque<double> latencies_ms;  // the last 2000 delivered frames

  void latency(double ms)
  {
    std::lock_guard<std::mutex> lock(m);
    latencies_ms.push_back(ms);
    if (latencies_ms.size() > 2000)
      latencies_ms.pop_front();
  }
  std::string line()
  {
    std::vector<double> l;
    {
      std::lock_guard<std::mutex> lock(m);
      l.assign(latencies_ms.begin(), latencies_ms.end());
    }
    std::sort(l.begin(), l.end());
    auto pct = [&](double p) { return l.empty() ? 0.0 : l[std::min(l.size() - 1, static_cast<std::size_t>(p * l.size()))]; };
    char buf[512];
    std::snprintf(buf, sizeof(buf),
                  "frames in %llu out %llu dropped %llu bad %llu sink-errors %llu | latency ms p50 %.1f p99 %.1f | points in %llu out %llu",
                  static_cast<unsigned long long>(in), static_cast<unsigned long long>(out),
                  static_cast<unsigned long long>(dropped), static_cast<unsigned long long>(bad),
                  static_cast<unsigned long long>(sink_errors), pct(0.5), pct(0.99),
                  static_cast<unsigned long long>(points_in), static_cast<unsigned long long>(points_out));
    return buf;
  }
};

/// Finished frames wait here until every earlier one is done: the sink sees them in order. At most
/// `capacity` finished frames wait (the one the sink needs next is always taken): a sink that
/// cannot deliver holds up the workers, and so the queue and its policy, instead of piling up.
class Reorder
{
public:
  explicit Reorder(std::size_t capacity) : capacity_(std::max<std::size_t>(1, capacity)) {}
  void put(std::uint64_t seq, std::optional<Outcome> outcome)  // nullopt: skipped (bad, dropped)
  {
    std::unique_lock<std::mutex> lock(m_);
    if (outcome)  // g_stop comes from a signal handler, which notifies no one: look every 100 ms
      while (!(held_ < capacity_ || seq == next_ || g_stop))
        cv_.wait_for(lock, std::chrono::milliseconds(100));
    held_ += outcome ? 1 : 0;
    done_[seq] = std::move(outcome);
    cv_.notify_all();
  }
  /// The next frame in order; false when the input has ended and all is delivered.
  bool next(std::optional<Outcome>& out)
  {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [&] { return done_.count(next_) || (ended_ && next_ >= total_); });
    if (!done_.count(next_))
      return false;
    out = std::move(done_[next_]);
    held_ -= out ? 1 : 0;
    done_.erase(next_++);
    cv_.notify_all();  // room for a worker waiting to put
    return true;
  }
  void end(std::uint64_t total)
  {
    std::lock_guard<std::mutex> lock(m_);
    ended_ = true;
    total_ = total;
    cv_.notify_all();
  }

private:
  std::mutex m_;
  std::condition_variable cv_;
  std::map<std::uint64_t, std::optional<Outcome>> done_;
  std::size_t capacity_, held_ = 0;
  std::uint64_t next_ = 0, total_ = 0;
  bool ended_ = false;
};

/// The bounded queue between the source and the workers.
class FrameQueue
{
public:
  FrameQueue(std::size_t capacity, bool drop_oldest, Stats& stats, Reorder& reorder)
    : capacity_(capacity), drop_oldest_(drop_oldest), stats_(stats), reorder_(reorder)
  {
  }
  void push(Frame f)
  {
    std::unique_lock<std::mutex> lock(m_);
    if (drop_oldest_)
    {
      while (q_.size() >= capacity_)
      {
        const std::uint64_t seq = q_.front().seq;
        q_.pop_front();
        ++stats_.dropped;
        std::fprintf(stderr, "ecs_node: frame %llu dropped (queue full)\n", static_cast<unsigned long long>(seq));
        reorder_.put(seq, std::nullopt);
      }
    }
    else
      not_full_.wait(lock, [&] { return q_.size() < capacity_; });
    q_.push_back(std::move(f));
    not_empty_.notify_one();
  }
  bool pop(Frame& f)
  {
    std::unique_lock<std::mutex> lock(m_);
    not_empty_.wait(lock, [&] { return !q_.empty() || closed_; });
    if (q_.empty())
      return false;
    f = std::move(q_.front());
    q_.pop_front();
    not_full_.notify_one();
    return true;
  }
  void close()
  {
    std::lock_guard<std::mutex> lock(m_);
    closed_ = true;
    not_empty_.notify_all();
  }

private:
  std::size_t capacity_;
  bool drop_oldest_;
  Stats& stats_;
  Reorder& reorder_;
  std::mutex m_;
  std::condition_variable not_full_, not_empty_;
  std::deque<Frame> q_;
  bool closed_ = false;
};

/// A frame named *.las / *.laz (a directory source's file), else PCD.
io::Format frameFormat(const Frame& f)
{
  const io::Format format = f.name.empty() ? io::Format::Pcd : io::formatFromPath(f.name);
  return format == io::Format::Las || format == io::Format::Laz ? format : io::Format::Pcd;
}

/// Simplify one frame; throws with the reason when it cannot be parsed or processed. A LAS / LAZ
/// frame is written back as LAS / LAZ with its header when `keep_las` (a directory sink), else as
/// binary PCD with every LAS dimension as a field (the framing of TCP and pipes carries PCD).
Outcome process(const Frame& f, const Parameters& params, std::uint64_t max_bytes, bool keep_las)
{
  if (!f.refused.empty())
    throw std::runtime_error(f.refused);
  const io::Format format = frameFormat(f);
  pcl::PCLPointCloud2 blob;
  io::LasInfo las;
  if (format != io::Format::Pcd)
  {
    std::uint64_t points = 0, step = 0;
    io::probeLas(f.bytes.substr(0, 375), f.bytes.size(), points, step);
    if (points * step > max_bytes)
      throw std::runtime_error(std::to_string(points) + " points of " + std::to_string(step) +
                               " bytes exceed --max-frame-bytes " + std::to_string(max_bytes));
    io::parseLas(f.bytes, blob, &las);
  }
  else
  {
    // The header says what the frame decodes to: refused before a compressed frame can expand.
    std::istringstream lines(f.bytes.substr(0, std::min<std::size_t>(f.bytes.size(), 64u << 10)));
    const io::PcdHeader h = io::parsePcdHeader([&](std::string& line) { return static_cast<bool>(std::getline(lines, line)); },
                                               std::numeric_limits<std::uint64_t>::max());
    if (h.points * h.point_step > max_bytes)
      throw std::runtime_error(std::to_string(h.points) + " points of " + std::to_string(h.point_step) +
                               " bytes exceed --max-frame-bytes " + std::to_string(max_bytes));
    io::parsePcd(f.bytes, blob);
  }
  Outcome out;
  out.name = f.name;
  out.arrived = f.arrived;
  out.points_in = static_cast<std::size_t>(blob.width) * blob.height;
  const tools::CloudRun run = tools::simplifyCloud(blob, params, tools::CloudRunOptions{});
  if (!run.result.error.empty())
    throw std::runtime_error(run.result.error);
  out.bytes = format != io::Format::Pcd && keep_las ? io::lasBytes(run.output, &las, format == io::Format::Laz)
                                                    : serializeBinaryPcd(run.output);
  out.points_out = run.result.labels.size();
  out.ok = true;
  return out;
}

/// Producers connected at once to a TCP source, each with its reader (more are refused).
constexpr std::size_t kMaxConnections = 256;

/// Reads frames from the source until it ends or the node is stopped; returns the count.
std::uint64_t runSource(const Options& o, FrameQueue& queue, Stats& stats, ByteBudget& budget)
{
  const Endpoint e = parseEndpoint(o.source, true);
  std::uint64_t seq = 0;
  std::mutex accept_mutex;  // connections read in parallel; frames are numbered as they complete
  auto accept_frame = [&](std::string bytes, ByteBudget::Reservation held, const std::string& name,
                          const std::string& refused = std::string()) {
    std::lock_guard<std::mutex> lock(accept_mutex);
    Frame f;
    f.seq = seq++;
    f.name = name;
    f.bytes = std::move(bytes);
    f.held = std::move(held);
    f.refused = refused;
    f.arrived = Clock::now();
    ++stats.in;
    queue.push(std::move(f));
  };
  auto read_stream = [&](int fd, int timeout_ms) {
    std::string bytes;
    ByteBudget::Reservation held;
    const FrameLimits limits{o.max_frame_bytes, timeout_ms, &budget};
    try
    {
      while (!g_stop && readFrame(fd, bytes, &g_stop, limits, &held))
        accept_frame(std::move(bytes), std::move(held), "");
    }
    catch (const StreamError& err)
    {
      // A frame cut short (by the stop, a timeout, or a peer that went away) came in and is
      // dropped; a refused length never started one.
      if (g_stop || held.bytes() > 0)
      {
        ++stats.in;
        ++stats.dropped;
      }
      std::fprintf(stderr, "ecs_node: source: %s; dropping the connection\n", tools::printable(err.what()).c_str());
    }
  };
  if (e.kind == Endpoint::Kind::Stdio)
    read_stream(STDIN_FILENO, -1);
  else if (e.kind == Endpoint::Kind::Tcp)
  {
    // Every connection has a reader of its own: an idle or slow producer holds up no other.
    const int lfd = listenTcp(e.port);
    struct Reader
    {
      std::thread thread;
      std::shared_ptr<std::atomic<bool>> done;
    };
    std::list<Reader> readers;
    auto reap = [&] {
      for (auto it = readers.begin(); it != readers.end();)
        if (it->done->load())
        {
          it->thread.join();
          it = readers.erase(it);
        }
        else
          ++it;
    };
    while (!g_stop)
    {
      const int fd = acceptTcp(lfd, 100);
      reap();
      if (fd < 0)
        continue;
      if (readers.size() >= kMaxConnections)
      {
        std::fprintf(stderr, "ecs_node: source: %zu connections already open; one more refused\n", readers.size());
        ::close(fd);
        continue;
      }
      auto done = std::make_shared<std::atomic<bool>>(false);
      const int timeout_ms = o.read_timeout > 0 ? static_cast<int>(o.read_timeout * 1000.0) : -1;
      readers.push_back({std::thread([&read_stream, fd, done, timeout_ms] {
                           read_stream(fd, timeout_ms);
                           ::close(fd);
                           done->store(true);
                         }),
                         done});
    }
    ::close(lfd);
    for (auto& r : readers)
      r.thread.join();
  }
  else  // directory
  {
    std::set<std::string> seen, skipped;
    std::map<std::string, std::uintmax_t> pending;  // name -> size at the last poll
    while (!g_stop)
    {
      std::vector<std::string> names;
      std::error_code ec;
      for (const auto& entry : fs::directory_iterator(e.path, ec))
      {
        const std::string name = entry.path().filename().string();
        const io::Format format = io::formatFromPath(name);
        if (name.empty() || name[0] == '.' || seen.count(name) ||
            (format != io::Format::Pcd && format != io::Format::Las && format != io::Format::Laz))
          continue;
        // Regular files only (a symlink is followed): a FIFO, a socket or a dangling link is
        // never a frame, and is skipped instead of waited for.
        std::error_code type_ec;
        if (!entry.is_regular_file(type_ec))
        {
          if (skipped.insert(name).second)
            std::fprintf(stderr, "ecs_node: source: %s is not a regular file; skipped\n",
                         tools::printable(name, 120).c_str());
          continue;
        }
        names.push_back(name);
      }
      std::sort(names.begin(), names.end());
      bool waiting = false;
      for (const auto& name : names)
      {
        const fs::path p = fs::path(e.path) / name;
        const std::uintmax_t size = fs::file_size(p, ec);
        if (ec)
          continue;
        auto it = pending.find(name);
        if (it == pending.end() || it->second != size)
        {
          pending[name] = size;  // seen for the first time, or still growing: wait a poll
          waiting = true;
          break;  // keep name order: nothing after an unfinished file
        }
        seen.insert(name);
        pending.erase(name);
        if (size > o.max_frame_bytes)
        {
          accept_frame(std::string(), ByteBudget::Reservation(), name,
                       "its " + std::to_string(size) + " bytes exceed --max-frame-bytes " +
                           std::to_string(o.max_frame_bytes));  // never read; counted as bad
          continue;
        }
        ByteBudget::Reservation held = budget.acquire(size, &g_stop);
        if (held.bytes() != size && size > 0)
          break;  // stopped while waiting for room
        std::ifstream in(p, std::ios::binary);
        std::string bytes;
        bytes.reserve(size);
        bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        if (bytes.size() > size)  // grew after its size was taken: read only what was reserved
          bytes.resize(size);
        accept_frame(std::move(bytes), std::move(held), name);
      }
      if (o.once && !waiting)
      {
        // Everything present has been read once its size was stable.
        bool any_left = false;
        for (const auto& name : names)
          any_left = any_left || !seen.count(name);
        if (!any_left)
          break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(o.poll_ms));
    }
  }
  return seq;
}

/// Delivers outcomes in order until the input has ended and everything is delivered.
void runSink(const Options& o, Reorder& reorder, Stats& stats)
{
  const Endpoint e = parseEndpoint(o.sink, false);
  int fd = e.kind == Endpoint::Kind::Stdio ? STDOUT_FILENO : -1;
  int lfd = e.kind == Endpoint::Kind::TcpListen ? listenTcp(e.port) : -1;
  std::uint64_t delivered = 0;
  std::optional<Outcome> next;
  while (reorder.next(next))
  {
    if (!next)
      continue;  // a bad or dropped frame: already counted and reported
    const Outcome& out = *next;
    try
    {
      if (e.kind == Endpoint::Kind::Dir)
      {
        char buf[64];
        std::snprintf(buf, sizeof(buf), "frame_%010llu.pcd", static_cast<unsigned long long>(delivered));
        const std::string name = out.name.empty() ? std::string(buf) : out.name;
        io::AtomicOutput file((fs::path(e.path) / name).string());
        {
          std::ofstream f(file.tempPath(), std::ios::binary);
          f.write(out.bytes.data(), static_cast<std::streamsize>(out.bytes.size()));
          if (!f)
            throw StreamError("cannot write " + file.tempPath());
        }
        file.commit();
      }
      else
      {
        while (fd < 0)
        {
          if (g_stop)
            throw StreamError("stopped before a consumer was connected");
          fd = e.kind == Endpoint::Kind::Tcp ? connectTcp(e.host, e.port) : acceptTcp(lfd, 200);
          if (fd < 0)
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
        writeFrame(fd, out.bytes, &g_stop);  // a consumer that does not read cannot hold up a stop
      }
      ++delivered;
      ++stats.out;
      stats.points_out += out.points_out;
      stats.latency(std::chrono::duration<double, std::milli>(Clock::now() - out.arrived).count());
    }
    catch (const std::exception& err)
    {
      ++stats.sink_errors;
      std::fprintf(stderr, "ecs_node: sink: %s; frame lost\n", tools::printable(err.what()).c_str());
      if (fd >= 0 && fd != STDOUT_FILENO)
      {
        ::close(fd);
        fd = -1;
      }
    }
  }
  if (fd >= 0 && fd != STDOUT_FILENO)
    ::close(fd);
  if (lfd >= 0)
    ::close(lfd);
}

int runNode(int argc, char** argv)
{
  bool done = false;
  const Options o = parseArgs(argc, argv, done);
  if (done)
    return tools::kExitOk;
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  const Endpoint src = parseEndpoint(o.source, true), snk = parseEndpoint(o.sink, false);
  if (src.kind == Endpoint::Kind::Dir && !fs::is_directory(src.path))
    throw tools::UsageError("source directory " + src.path + " does not exist");
  if (snk.kind == Endpoint::Kind::Dir && !fs::is_directory(snk.path))
    throw tools::UsageError("sink directory " + snk.path + " does not exist");
  std::error_code same_ec;
  if (src.kind == Endpoint::Kind::Dir && snk.kind == Endpoint::Kind::Dir && fs::equivalent(src.path, snk.path, same_ec))
    throw tools::UsageError("source and sink are the same directory (" + snk.path +
                            "): the outputs would be read as new frames and the inputs overwritten");

  struct sigaction sa{};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);

  const bool sink_is_dir = snk.kind == Endpoint::Kind::Dir;
  Stats stats;
  ByteBudget budget(o.max_bytes_in_flight);
  Reorder reorder(o.queue);
  FrameQueue queue(o.queue, o.drop_oldest, stats, reorder);
  std::vector<std::thread> workers;
  for (int w = 0; w < o.workers; ++w)
    workers.emplace_back([&] {
      Frame f;
      while (queue.pop(f))
      {
        try
        {
          Outcome out = process(f, o.params, o.max_frame_bytes, sink_is_dir);
          const std::uint64_t seq = f.seq;
          f = Frame{};  // the input's bytes and its share of the budget go back now
          stats.points_in += out.points_in;
          reorder.put(seq, std::move(out));
        }
        catch (const std::exception& err)
        {
          ++stats.bad;
          std::fprintf(stderr, "ecs_node: frame %llu%s%s is bad: %s\n", static_cast<unsigned long long>(f.seq),
                       f.name.empty() ? "" : " ", tools::printable(f.name, 120).c_str(),
                       tools::printable(err.what()).c_str());
          reorder.put(f.seq, std::nullopt);
        }
        f = Frame{};
      }
    });
  std::thread sink([&] { runSink(o, reorder, stats); });
  std::atomic<bool> finished{false};
  std::thread ticker([&] {
    auto last = Clock::now();
    while (!finished)
    {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      if (o.stats_interval > 0 && !o.quiet &&
          std::chrono::duration<double>(Clock::now() - last).count() >= o.stats_interval)
      {
        last = Clock::now();
        std::fprintf(stderr, "ecs_node: %s\n", stats.line().c_str());
      }
    }
  });
  if (!o.quiet)
    std::fprintf(stderr, "ecs_node: %s -> %s, %d workers, queue %zu (%s)\n", o.source.c_str(), o.sink.c_str(),
                 o.workers, o.queue, o.drop_oldest ? "drop-oldest" : "block");

  std::uint64_t total = 0;
  try
  {
    total = runSource(o, queue, stats, budget);
  }
  catch (const std::exception& err)
  {
    std::fprintf(stderr, "ecs_node: source: %s\n", tools::printable(err.what()).c_str());
    g_stop = true;
  }
  // Finish the frames in flight, flush the sink.
  queue.close();
  for (auto& w : workers)
    w.join();
  reorder.end(total);
  sink.join();
  finished = true;
  ticker.join();
  std::fprintf(stderr, "ecs_node: summary: %s\n", stats.line().c_str());
  return tools::kExitOk;
}

}  // namespace

int main(int argc, char** argv)
{
#ifdef __GLIBC__
  // Frames are large and come and go on many threads: served by mmap and given back when freed,
  // so --max-bytes-in-flight bounds the resident set (glibc would otherwise raise the threshold
  // after the first free and keep freed frames in each thread's arena).
  ::mallopt(M_MMAP_THRESHOLD, 1 << 20);
#endif
  try
  {
    return runNode(argc, argv);
  }
  catch (const tools::UsageError& e)
  {
    std::fprintf(stderr, "ecs_node: %s\n", tools::printable(e.what()).c_str());
    return tools::kExitUsage;
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "ecs_node: internal error: %s\n", tools::printable(e.what()).c_str());
    return tools::kExitInternal;
  }
}

// scratch.cpp — the out-of-core run's scratch files, the process's memory and the tile threads (tiled_run.h).
#include "tiled_run.h"

namespace pcl_ecs
{
namespace stream
{
namespace detail
{

/// The process's resident memory now (0 when /proc cannot tell).
std::uint64_t residentBytes()
{
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size = 0, resident = 0;
  if (!(statm >> size >> resident))
    return 0;
  return resident * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
}

// ---- scratch files: written under a temporary name, renamed when complete -------------------
void writeFileAtomic(const fs::path& path, const void* data, std::size_t bytes)
{
  // A name of this process and call: two processes that write the same file (a task run again
  // while a worker thought lost still runs it) never write into one temporary; the last rename
  // wins, with the same bytes.
  static std::atomic<std::uint64_t> serial{0};
  const fs::path tmp = path.string() + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(serial++);
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
    f.flush();
    if (!f)
      failRun("cannot write " + tmp.string() + " (disk full?)");
  }
  fs::rename(tmp, path);
}

std::size_t appendFile(const fs::path& path, std::vector<std::uint8_t>& into)
{
  std::ifstream f(path, std::ios::binary | std::ios::ate);
  if (!f)
    failRun("cannot read the scratch file " + path.string());
  const auto bytes = static_cast<std::size_t>(f.tellg());
  f.seekg(0);
  const std::size_t at = into.size();
  into.resize(at + bytes);
  f.read(reinterpret_cast<char*>(into.data() + at), static_cast<std::streamsize>(bytes));
  if (!f)
    failRun("cannot read the scratch file " + path.string());
  return bytes;
}

/// File descriptors this process can still open: its soft limit less those open now.
std::uint64_t freeFileDescriptors()
{
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY)
    return std::uint64_t{1} << 20;
  std::uint64_t open = 0;
  std::error_code ec;
  for (auto it = fs::directory_iterator("/proc/self/fd", ec); !ec && it != fs::directory_iterator(); it.increment(ec))
    ++open;
  if (ec)
    open = 16;  // no /proc: a guess
  return limit.rlim_cur > open ? limit.rlim_cur - open : 0;
}

std::uint64_t directoryBytes(const fs::path& dir)
{
  std::uint64_t total = 0;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_regular_file(ec))
      total += it->file_size(ec);
  return total;
}

FileStamp stampOf(const fs::path& file)
{
  std::error_code size_error, time_error;
  FileStamp s;
  s.size = fs::file_size(file, size_error);
  s.mtime = fs::last_write_time(file, time_error).time_since_epoch().count();
  s.known = !size_error && !time_error;
  return s;
}

/// Runs fn(tile) for every tile in `tiles` on `workers` threads; the first exception wins.
void forEachTile(const std::vector<int>& tiles, int workers, const std::function<void(int)>& fn)
{
  std::atomic<std::size_t> next{0};
  std::mutex m;
  std::exception_ptr error;
  auto work = [&]() {
    for (;;)
    {
      {
        std::lock_guard<std::mutex> lock(m);
        if (error)
          return;
      }
      const std::size_t i = next++;
      if (i >= tiles.size())
        return;
      try
      {
        fn(tiles[i]);
      }
      catch (...)
      {
        std::lock_guard<std::mutex> lock(m);
        if (!error)
          error = std::current_exception();
        return;
      }
    }
  };
  std::vector<std::thread> pool;
  for (int w = 1; w < std::min<int>(workers, static_cast<int>(tiles.size())); ++w)
    pool.emplace_back(work);
  work();
  for (auto& t : pool)
    t.join();
  if (error)
    std::rethrow_exception(error);
}

}  // namespace detail
}  // namespace stream
}  // namespace pcl_ecs

// seeded_order.h — the order in which ball centres are picked (section 4, step 3). The paper picks
// "without regard to the order"; a seeded order makes a run reproducible bit for bit on every
// platform: splitmix64 and a Fisher-Yates shuffle written out here, because std::shuffle and
// std::uniform_int_distribution are implementation-defined.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace pcl_ecs
{

/** \brief splitmix64: a tiny, fully specified 64-bit generator. */
class SplitMix64
{
public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next()
  {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /** \brief Uniform in [0, bound), bound > 0 (Lemire's multiply-shift with rejection). */
  std::uint64_t below(std::uint64_t bound)
  {
    const std::uint64_t threshold = (0 - bound) % bound;
    for (;;)
    {
      const std::uint64_t r = next();
      const unsigned __int128 m = static_cast<unsigned __int128>(r) * bound;
      if (static_cast<std::uint64_t>(m) >= threshold)
        return static_cast<std::uint64_t>(m >> 64);
    }
  }

private:
  std::uint64_t state_;
};

/** \brief Shuffle items[0, count) in place with Fisher-Yates driven by SplitMix64(seed). */
template <typename T>
void seededShuffle(T* items, std::size_t count, std::uint64_t seed)
{
  SplitMix64 rng(seed);
  for (std::size_t i = count; i > 1; --i)
  {
    const std::size_t j = static_cast<std::size_t>(rng.below(i));
    std::swap(items[i - 1], items[j]);
  }
}

/** \brief Shuffle `items` in place with Fisher-Yates driven by SplitMix64(seed). */
template <typename T, typename A>
void seededShuffle(std::vector<T, A>& items, std::uint64_t seed)
{
  seededShuffle(items.data(), items.size(), seed);
}

/** \brief A seed for one part of a run (a cell, a tile) drawn from the run's seed and the part's
 * key: different parts get unrelated streams, and a part's stream depends on nothing else. */
inline std::uint64_t partSeed(std::uint64_t seed, std::uint64_t key)
{
  SplitMix64 mix(seed ^ (key * 0x9E3779B97F4A7C15ull));
  mix.next();
  return mix.next();
}

}  // namespace pcl_ecs

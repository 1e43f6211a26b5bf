// pair_key.h (private) — a (squared distance, index) pair packed into one 64-bit integer whose
// order is the pair's (distance first, then index): the bits of a non-negative float order like
// the float. Shared by the K-neighbourhood pass and the box-tree search, which rank neighbours
// exactly by this order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace pcl_ecs
{

/// (squared distance, index) as one integer that orders like the pair (distance >= 0, index >= 0).
inline std::uint64_t pairKey(float d2, int index)
{
  std::uint32_t bits;
  std::memcpy(&bits, &d2, sizeof bits);
  return (static_cast<std::uint64_t>(bits) << 32) | static_cast<std::uint32_t>(index);
}

inline float keyDistance(std::uint64_t key)
{
  const auto bits = static_cast<std::uint32_t>(key >> 32);
  float d2;
  std::memcpy(&d2, &bits, sizeof d2);
  return d2;
}

inline int keyIndex(std::uint64_t key)
{
  return static_cast<int>(static_cast<std::uint32_t>(key));
}

/// The indices and squared distances of `count` keys, in their order.
inline void unpackKeys(const std::uint64_t* keys, std::size_t count, int* indices, float* sqr_distances)
{
  for (std::size_t i = 0; i < count; ++i)
  {
    indices[i] = keyIndex(keys[i]);
    sqr_distances[i] = keyDistance(keys[i]);
  }
}

}  // namespace pcl_ecs

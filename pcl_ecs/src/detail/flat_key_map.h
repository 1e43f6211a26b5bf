// flat_key_map.h (private) — a hash map from 64-bit keys to small values in one flat array: open
// addressing with linear probing, at most half full, an erased entry closed up by shifting back
// the entries after it (no tombstones). For the hot tables that a node-based map would pay an
// allocation an entry for: the cells of a PointGrid (detail/point_grid.h), the edges of the
// Cocone clean-up (surface/cocone_detail.h). The key ~0 is reserved (no user of it packs a key
// with every bit set).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace pcl_ecs
{

template <class V>
class FlatKeyMap
{
public:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};

  /// Room for `n` entries without growing.
  void reserve(std::size_t n)
  {
    std::size_t size = 16;
    while (size < 2 * n)
      size *= 2;
    if (size > slots_.size())
      rehash(size);
  }
  std::size_t size() const { return size_; }

  /// The value of `key`, or nullptr.
  V* find(std::uint64_t key)
  {
    if (slots_.empty())
      return nullptr;
    Slot& s = slots_[slotOf(key)];
    return s.key == key ? &s.value : nullptr;
  }
  const V* find(std::uint64_t key) const { return const_cast<FlatKeyMap*>(this)->find(key); }
  bool contains(std::uint64_t key) const { return find(key) != nullptr; }

  /// The value of `key`, made (V{}) when there is none, and whether it was made now. A pointer to a
  /// value stays valid until the next insertion or erasure.
  std::pair<V*, bool> insert(std::uint64_t key)
  {
    if (2 * (size_ + 1) > slots_.size())
      rehash(std::max<std::size_t>(16, 2 * slots_.size()));
    Slot& s = slots_[slotOf(key)];
    const bool made = s.key != key;
    if (made)
    {
      s = {key, V{}};
      ++size_;
    }
    return {&s.value, made};
  }
  /// The value of `key`, made (V{}) when there is none.
  V& operator[](std::uint64_t key) { return *insert(key).first; }

  void erase(std::uint64_t key)
  {
    if (slots_.empty())
      return;
    const std::size_t mask = slots_.size() - 1;
    std::size_t hole = slotOf(key);
    if (slots_[hole].key != key)
      return;
    --size_;
    // Backward shift: an entry after the hole moves into it unless its home lies cyclically in
    // (hole, its slot].
    for (std::size_t j = (hole + 1) & mask; slots_[j].key != kEmpty; j = (j + 1) & mask)
    {
      const std::size_t home = homeOf(slots_[j].key);
      if (((j - home) & mask) >= ((j - hole) & mask))
      {
        slots_[hole] = slots_[j];
        hole = j;
      }
    }
    slots_[hole].key = kEmpty;
  }

  /// f(key, value) for every entry, in slot order.
  template <class F>
  void forEach(F&& f) const
  {
    for (const Slot& s : slots_)
      if (s.key != kEmpty)
        f(s.key, s.value);
  }

private:
  struct Slot
  {
    std::uint64_t key;
    V value;
  };
  std::size_t homeOf(std::uint64_t key) const
  {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
  }
  /// The slot holding `key`, or the empty slot where it would go (the table is never full).
  std::size_t slotOf(std::uint64_t key) const
  {
    const std::size_t mask = slots_.size() - 1;
    std::size_t h = homeOf(key);
    while (slots_[h].key != key && slots_[h].key != kEmpty)
      h = (h + 1) & mask;
    return h;
  }
  void rehash(std::size_t size)  // a power of two
  {
    shift_ = 64;
    for (std::size_t x = size; x > 1; x >>= 1)
      --shift_;
    std::vector<Slot> old(size, Slot{kEmpty, V{}});
    old.swap(slots_);
    for (const Slot& e : old)
      if (e.key != kEmpty)
        slots_[slotOf(e.key)] = e;
  }

  std::vector<Slot> slots_;  // empty until the first insertion or reserve
  std::size_t size_ = 0;
  int shift_ = 64;
};

}  // namespace pcl_ecs

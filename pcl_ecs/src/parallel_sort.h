// parallel_sort.h (private) — sort with a given number of threads. Meant for keys that are all
// distinct (or a comparator that is a strict total order): then every correct sort, parallel or
// not, gives the one order, whatever the thread count.
#pragma once

#include <algorithm>
#include <functional>
#include <parallel/algorithm>

namespace pcl_ecs
{

template <class It, class Less = std::less<>>
void sortWithThreads(It first, It last, int threads, Less less = Less())
{
  if (threads > 1)
    __gnu_parallel::sort(first, last, less,
                         __gnu_parallel::default_parallel_tag(static_cast<__gnu_parallel::_ThreadIndex>(threads)));
  else
    std::sort(first, last, less);
}

}  // namespace pcl_ecs

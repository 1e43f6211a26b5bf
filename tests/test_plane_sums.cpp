// The private loops of E(r) (pcl_ecs/src/plane_sums.h): the AVX2 and the portable versions against
// plain scalar loops, bit for bit.
#include "detail/plane_sums.h"
#include "detail/simd.h"

#include <pcl_ecs/stages/kernel.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace
{
using pcl_ecs::CandidatePlanes;

struct Case
{
  std::vector<CandidatePlanes::Terms> terms;
  std::vector<std::uint32_t> idx;
  std::vector<double> g;
};

Case randomCase(std::size_t planes, std::size_t count, unsigned seed)
{
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> value(-1e3, 1e3), weight(0.0, 1.0);
  Case c;
  c.terms.resize(planes);
  for (auto& t : c.terms)
    for (double& v : t.t)
      v = value(rng) * std::ldexp(1.0, static_cast<int>(rng() % 40) - 20);  // many magnitudes
  std::uniform_int_distribution<std::uint32_t> pick(0, static_cast<std::uint32_t>(planes - 1));
  for (std::size_t s = 0; s < count; ++s)
  {
    c.idx.push_back(pick(rng));
    c.g.push_back(weight(rng));
  }
  return c;
}

/// The documented order: plane s into running sum s % 2, the two sums added at the end.
void reference(const Case& c, double* sum)
{
  double acc[2][12] = {};
  for (std::size_t s = 0; s < c.idx.size(); ++s)
    for (int k = 0; k < 12; ++k)
    {
      const double product = c.g[s] * c.terms[c.idx[s]].t[k];
      acc[s % 2][k] = acc[s % 2][k] + product;
    }
  for (int k = 0; k < 12; ++k)
    sum[k] = acc[0][k] + acc[1][k];
}

TEST(PlaneSums, EveryVersionGivesTheSameBitsAsTheScalarLoop)
{
  for (const std::size_t count : {0u, 1u, 2u, 3u, 7u, 64u, 173u, 1000u})
  {
    const Case c = randomCase(300, count, static_cast<unsigned>(count) + 11u);
    double expected[12], portable[12], wide[12];
    reference(c, expected);
    pcl_ecs::detail::allowAvx2(false);
    pcl_ecs::detail::weightedPlaneSum(c.terms.data(), c.idx.data(), c.g.data(), count, portable);
    pcl_ecs::detail::allowAvx2(true);
    pcl_ecs::detail::weightedPlaneSum(c.terms.data(), c.idx.data(), c.g.data(), count, wide);
    EXPECT_EQ(0, std::memcmp(expected, portable, sizeof expected)) << count << " planes";
    EXPECT_EQ(0, std::memcmp(expected, wide, sizeof expected))
        << count << " planes, AVX2 " << pcl_ecs::detail::useAvx2();
  }
  if (!pcl_ecs::detail::useAvx2())
    GTEST_SKIP() << "no AVX2 on this CPU: the portable version alone was checked";
}

TEST(PlaneSums, AlternatingChainsAddEveryPlaneOnce)
{
  // Exact small integers: any order gives the exact total, so a plane dropped or counted twice shows.
  Case c;
  c.terms.resize(5);
  for (std::size_t p = 0; p < 5; ++p)
    for (int k = 0; k < 12; ++k)
      c.terms[p].t[k] = static_cast<double>((p + 1) * (k + 1));
  c.idx = {0, 1, 2, 3, 4, 4, 0};
  c.g = {1, 2, 3, 4, 5, 6, 7};
  double sum[12];
  pcl_ecs::detail::weightedPlaneSum(c.terms.data(), c.idx.data(), c.g.data(), c.idx.size(), sum);
  // Σ g[s] (idx[s] + 1) = 1 + 4 + 9 + 16 + 25 + 30 + 7 = 92, times (k + 1).
  for (int k = 0; k < 12; ++k)
    EXPECT_EQ(92.0 * (k + 1), sum[k]) << "term " << k;
}
}  // namespace

TEST(PlaneSums, KernelPiecesSplitLikeTheKernelWithAndWithoutAvx2)
{
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> spread(0.0, 1.5);
  const double R = 0.8;
  for (const std::size_t m : {0u, 1u, 2u, 3u, 4u, 5u, 17u, 250u})
  {
    std::vector<double> dist((m + 3) & ~std::size_t{3}, std::numeric_limits<double>::infinity());
    for (std::size_t j = 0; j < m; ++j)
      dist[j] = j % 7 == 3 ? 0.5 * R : j % 7 == 5 ? R : spread(rng) * R;  // both boundaries too
    std::vector<std::uint32_t> want_in, want_out;
    for (std::size_t j = 0; j < m; ++j)
    {
      const double t = dist[j] * (1.0 / R);
      if (t <= 0.5)
        want_in.push_back(static_cast<std::uint32_t>(j));
      else if (t <= 1.0)
        want_out.push_back(static_cast<std::uint32_t>(j));
    }
    for (const bool avx2 : {false, true})
    {
      pcl_ecs::detail::allowAvx2(avx2);
      std::vector<std::uint32_t> in(m + 8), out(m + 8);
      std::size_t n_in = 99, n_out = 99;
      pcl_ecs::detail::selectKernelPieces(dist.data(), m, 1.0 / R, in.data(), n_in, out.data(), n_out);
      pcl_ecs::detail::allowAvx2(true);
      in.resize(n_in);
      out.resize(n_out);
      EXPECT_EQ(in, want_in) << m << " planes, AVX2 " << avx2;
      EXPECT_EQ(out, want_out) << m << " planes, AVX2 " << avx2;
    }
  }
}

// The kernel's weights of both pieces, with and without AVX2, bit for bit those of kernelInner /
// kernelOuter one at a time (counts not a multiple of the lane count; the outer positions are
// appended to the inner ones).
TEST(PlaneSums, KernelWeightsAreThePiecesOneByOneWithAndWithoutAvx2)
{
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> d(0.0, 1.0);
  std::vector<double> dist(203);
  for (double& x : dist)
    x = d(rng);
  const double inv_R = 1.0 / 0.8;
  std::vector<std::uint32_t> inner, outer;
  for (std::uint32_t j = 0; j < dist.size(); ++j)
  {
    const double t = dist[j] * inv_R;
    if (t <= 0.5)
      inner.push_back(j);
    else if (t <= 1.0)
      outer.push_back(j);
  }
  ASSERT_GT(inner.size(), 20u);
  ASSERT_GT(outer.size(), 20u);
  std::vector<double> expected;
  for (std::uint32_t j : inner)
    expected.push_back(pcl_ecs::kernelInner(dist[j] * inv_R));
  for (std::uint32_t j : outer)
    expected.push_back(pcl_ecs::kernelOuter(dist[j] * inv_R));
  for (bool avx2 : {false, true})
  {
    pcl_ecs::detail::allowAvx2(avx2);
    std::vector<std::uint32_t> idx = inner;
    idx.resize(inner.size() + outer.size());
    std::vector<double> g(idx.size());
    pcl_ecs::detail::kernelWeights(dist.data(), inv_R, idx.data(), inner.size(), outer.data(), outer.size(),
                                   g.data());
    EXPECT_EQ(0, std::memcmp(g.data(), expected.data(), g.size() * sizeof(double))) << "avx2 " << avx2;
    for (std::size_t s = 0; s < outer.size(); ++s)
      EXPECT_EQ(idx[inner.size() + s], outer[s]);
  }
  pcl_ecs::detail::allowAvx2(true);
}

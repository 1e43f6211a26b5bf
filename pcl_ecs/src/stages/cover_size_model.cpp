#include <pcl_ecs/stages/cover_size_model.h>

#include <algorithm>

namespace pcl_ecs
{

CoverSizeModel::CoverSizeModel(const std::vector<CoverBall>& balls, double cap, std::size_t gap_points)
  : gap_points_(static_cast<double>(gap_points))
{
  shares_.reserve(balls.size());
  const double at_cap = cap * (1.0 - 1e-9);
  for (const CoverBall& b : balls)
  {
    if (!(b.radius > 0.0) || !(b.tolerance > 0.0))
      shares_.push_back({1.0f, 0.0f, 0.0f});
    else if (b.radius < at_cap)
    {
      const auto share = static_cast<float>(b.radius * b.radius / (cap * cap));
      shares_.push_back({share, 1.0f, share});
    }
    else
      shares_.push_back({1.0f, static_cast<float>(std::max(b.error, 0.0) / b.tolerance), 1.0f});
  }
  for (const Share& m : shares_)
    at_cap_now_ += m.floor >= m.per_inv_s ? m.at_cap : 0.0f;
}

double CoverSizeModel::count(double s) const
{
  const double inv_s = 1.0 / s;
  double balls = 0.0, at_cap = 0.0;
  for (const Share& m : shares_)
  {
    balls += std::max(static_cast<double>(m.floor), static_cast<double>(m.per_inv_s) * inv_s);
    at_cap += s * m.floor >= m.per_inv_s ? m.at_cap : 0.0f;
  }
  return balls + (at_cap_now_ > 0.0 ? gap_points_ * at_cap / at_cap_now_ : gap_points_);
}

}  // namespace pcl_ecs

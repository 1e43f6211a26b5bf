#include <pcl_ecs/parameters.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <thread>

namespace pcl_ecs
{

const char* toString(ErrorForm form)
{
  return form == ErrorForm::Paper ? "paper" : "normalized";
}

bool parseErrorForm(const std::string& text, ErrorForm& form)
{
  if (text == "normalized")
  {
    form = ErrorForm::Normalized;
    return true;
  }
  if (text == "paper")
  {
    form = ErrorForm::Paper;
    return true;
  }
  return false;
}

int resolveThreads(int requested)
{
  if (requested > 0)
    return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<int>(std::min(hw, 1024u));
}

}  // namespace pcl_ecs

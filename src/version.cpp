/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/render/map_picture.h>
#include <pcl_parallel/version.h>

#include <pcl/pcl_config.h>

#include <Eigen/Core>
#include <boost/version.hpp>

#include <nlohmann/json.hpp>

#ifndef PCL_PARALLEL_VERSION
#define PCL_PARALLEL_VERSION "unknown"
#endif

namespace pcl_parallel {

std::vector<std::pair<std::string, std::string>>
buildVersions()
{
  const auto version = [](int major, int minor, int patch) {
    return std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(patch);
  };
  return {{"pcl_parallel", PCL_PARALLEL_VERSION},
          {"pcl", PCL_VERSION_PRETTY},
          {"eigen", version(EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION)},
          {"boost", BOOST_LIB_VERSION},
          {"cairo", render::cairoVersion()},
          {"nlohmann_json",
           version(NLOHMANN_JSON_VERSION_MAJOR,
                   NLOHMANN_JSON_VERSION_MINOR,
                   NLOHMANN_JSON_VERSION_PATCH)},
          {"compiler", __VERSION__}};
}

} // namespace pcl_parallel

/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace pcl_parallel {

/** What the library was built with, as (name, version): pcl_parallel, pcl, eigen, boost,
 *  cairo, nlohmann_json and the compiler; for a run's report, so that a result can be
 *  traced to its build. */
std::vector<std::pair<std::string, std::string>>
buildVersions();

} // namespace pcl_parallel

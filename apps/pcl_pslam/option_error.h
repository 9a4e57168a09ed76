/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <boost/program_options/errors.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace pcl_pslam {

/** e.what(), except where an argument holds '%': Boost 1.74's message then substitutes a
 *  value holding its own placeholder ("%value%") again and again, for ever (a fuzz
 *  finding), so the message names the option alone. */
inline std::string
optionErrorMessage(const boost::program_options::error& e, const std::vector<std::string>& args)
{
  if (std::none_of(args.begin(), args.end(), [](const std::string& a) {
        return a.find('%') != std::string::npos;
      }))
    return e.what();
  const auto* named = dynamic_cast<const boost::program_options::error_with_option_name*>(&e);
  return "the option " + (named ? "'" + named->get_option_name() + "' " : std::string()) +
         "or its value is invalid";
}

} // namespace pcl_pslam

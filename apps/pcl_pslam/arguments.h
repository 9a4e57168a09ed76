/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * What the subcommands' parsers share: Boost.Program_options run one way, and its errors'
 * messages made safe.
 */
#pragma once

#include <boost/program_options.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace pcl_pslam {

/** `args` parsed by `options` and stored into their variables, the positional arguments
 *  named by `positional`; an abbreviated option is an error, not a guess. Throws
 *  boost::program_options::error. */
inline boost::program_options::variables_map
parseArguments(const std::vector<std::string>& args,
               const boost::program_options::options_description& options,
               const boost::program_options::positional_options_description& positional)
{
  namespace po = boost::program_options;
  po::variables_map vm;
  po::store(
      po::command_line_parser(args)
          .options(options)
          .positional(positional)
          .style(po::command_line_style::unix_style ^ po::command_line_style::allow_guessing)
          .run(),
      vm);
  po::notify(vm);
  return vm;
}

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

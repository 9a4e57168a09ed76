/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Private to src/: the file-name patterns of runs and scan sets (scanNNN.frames,
 * map_rankN.pcd, 000042.bin), matched by hand; <regex> would add seconds to each unit's
 * compile for these few fixed shapes.
 */
#pragma once

#include <cstddef>
#include <initializer_list>
#include <string_view>

namespace pcl_parallel {
namespace io {
namespace detail {

/** The count of decimal digits `name` starts with. */
inline std::size_t
leadingDigits(std::string_view name)
{
  std::size_t n = 0;
  while (n < name.size() && name[n] >= '0' && name[n] <= '9')
    ++n;
  return n;
}

/** True where `name` is `prefix`, then `digits` decimal digits (0: one or more), then one
 *  of `suffixes`: scan[0-9]{3}\.(3d|pose) is ("scan", 3, {".3d", ".pose"}). */
inline bool
isNumberedName(std::string_view name,
               std::string_view prefix,
               std::size_t digits,
               std::initializer_list<std::string_view> suffixes)
{
  if (name.substr(0, prefix.size()) != prefix)
    return false;
  name.remove_prefix(prefix.size());
  const std::size_t n = leadingDigits(name);
  if (n == 0 || (digits != 0 && n != digits))
    return false;
  name.remove_prefix(n);
  for (const std::string_view suffix : suffixes)
    if (name == suffix)
      return true;
  return false;
}

/** True where `name` is one of `names`. */
inline bool
isOneOf(std::string_view name, std::initializer_list<std::string_view> names)
{
  for (const std::string_view n : names)
    if (name == n)
      return true;
  return false;
}

} // namespace detail
} // namespace io
} // namespace pcl_parallel

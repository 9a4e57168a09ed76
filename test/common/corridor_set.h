/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/sim/simulated_scans.h>

namespace pcl_parallel {
namespace test {

/** A 20 x 14 m corridor floor, 1.1 laps (~38 scans: one loop to close), fewer rays than
 *  the demo: the pipeline tests' scan set, simulated once per test program. */
inline const sim::SimulatedScanSet&
corridorSet()
{
  static const sim::SimulatedScanSet set = [] {
    sim::SimulationParameters p;
    p.outer_length = 20.0;
    p.outer_width = 14.0;
    p.scanner.azimuth_steps = 360;
    p.scanner.elevation_steps = 64;
    return sim::simulateScanSet(p);
  }();
  return set;
}

} // namespace test
} // namespace pcl_parallel

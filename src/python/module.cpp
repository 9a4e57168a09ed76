/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "convert.h"

#include <pcl/console/print.h>

PYBIND11_MODULE(pcl_parallel, m)
{
  m.doc() = "pcl_parallel: parallel ICP (pICP), parallel Lu/Milios GraphSLAM (pLUM) and a "
            "streaming SLAM pipeline (Nuechter, ECMR 2007). Points are (N, 3) float32 or "
            "float64 arrays, poses (4, 4) float64 arrays, pose sequences (M, 4, 4). Every "
            "call releases the GIL while it computes; threads=None uses all cores.";
  m.attr("__version__") = PCL_PARALLEL_VERSION;
  // Errors reach Python as exceptions; PCL's own warnings stay on stderr, its chatter not.
  pcl::console::setVerbosityLevel(pcl::console::L_WARN);
  namespace python = pcl_parallel::python;
  python::bindErrors(m);
  python::bindRegistration(m);
  python::bindSearch(m);
  python::bindSlam(m);
  python::bindIo(m);
}

/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * mpi::Session in a build without MPI (session.cpp with): every process is rank 0 of 1.
 */
#include <pcl_parallel/mpi/session.h>

namespace pcl_parallel {
namespace mpi {

Session::Session(int&, char**&)
{}

Session::~Session() = default;

void
Session::agree(const std::function<void()>& step) const
{
  step();
}

bool
Session::collective(const std::exception&) const
{
  return false;
}

int
Session::broadcast(int value) const
{
  return value;
}

std::string
Session::broadcast(const std::string& text) const
{
  return text;
}

} // namespace mpi
} // namespace pcl_parallel

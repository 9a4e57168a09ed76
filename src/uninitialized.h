/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace detail {

/** An allocator whose value-less construct() default-initializes: resize() of trivial
 *  elements leaves them unset instead of zeroing them on the calling thread. For per-scan
 *  buffers a parallel loop fills at once, so that the pages are first touched (and
 *  faulted in) by the threads that write them (docs/design.md, "Serial work per scan"). */
template <typename T, typename Base = std::allocator<T>>
struct DefaultInitAllocator : Base {
  using Traits = std::allocator_traits<Base>;
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U, typename Traits::template rebind_alloc<U>>;
  };
  using Base::Base;

  template <typename U>
  void
  construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value)
  {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void
  construct(U* p, Args&&... args)
  {
    Traits::construct(static_cast<Base&>(*this), p, std::forward<Args>(args)...);
  }
};

/** A vector whose resize() leaves trivial elements unset (DefaultInitAllocator). */
template <typename T>
using UninitializedVector = std::vector<T, DefaultInitAllocator<T>>;

} // namespace detail
} // namespace pcl_parallel

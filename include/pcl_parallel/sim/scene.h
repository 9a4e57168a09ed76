/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace pcl_parallel {
namespace sim {

/** A solid axis-aligned box (walls, floor, crates). */
struct Box {
  /** Lower corner. */
  Eigen::Vector3d min;
  /** Upper corner. */
  Eigen::Vector3d max;
};

/** A solid vertical cylinder (pillars, tree trunks): axis through (x, y), z_min to z_max. */
struct Cylinder {
  /** Centre (x, y) and radius. */
  ///@{
  double x = 0.0, y = 0.0, radius = 0.5;
  ///@}
  /** Bottom and top. */
  ///@{
  double z_min = 0.0, z_max = 3.0;
  ///@}
};

/** A solid box at any orientation (ramps, slanted roofs, parked cars):
 *  p_world = rotation * p_box + centre, the box spanning [-half_size, half_size]. */
struct OrientedBox {
  /** Orientation. */
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  /** Centre. */
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  /** Half the size along each of its axes. */
  Eigen::Vector3d half_size = Eigen::Vector3d::Constant(0.5);
};

/** A two-sided triangle (uneven ground as a height field). */
struct Triangle {
  /** The corners. */
  ///@{
  Eigen::Vector3d a, b, c;
  ///@}
};

/** The world the scanner sees: primitives, metres. */
struct World {
  /** Axis-aligned boxes. */
  std::vector<Box> boxes;
  /** Vertical capped cylinders. */
  std::vector<Cylinder> cylinders;
  /** Oriented boxes. */
  std::vector<OrientedBox> oriented_boxes;
  /** Two-sided triangles. */
  std::vector<Triangle> triangles;

  /** Distance along the unit direction dir from origin to the first surface hit with
   *  distance in (0, max_range]; returns false if there is none. A ray starting inside
   *  a solid hits its far side. Tests every primitive: the reference for RayCaster. */
  bool
  raycast(const Eigen::Vector3d& origin,
          const Eigen::Vector3d& dir,
          double max_range,
          double& range) const;
};

/** A bounding volume hierarchy over a World's primitives (median split on the longest
 *  axis, 4 primitives a leaf): ray casting in O(log n) instead of O(n). Returns exactly
 *  World::raycast's range (the same intersection code; boxes are padded so pruning never
 *  drops the nearest hit). Copies the primitives: the World may go away. Thread-safe
 *  for concurrent raycast calls. */
class RayCaster {
public:
  /** A BVH over the primitives of \a world (which must outlive it). */
  explicit RayCaster(const World& world);

  /** As World::raycast. */
  bool
  raycast(const Eigen::Vector3d& origin,
          const Eigen::Vector3d& dir,
          double max_range,
          double& range) const;

  /** Primitives indexed. */
  std::size_t
  size() const
  {
    return refs_.size();
  }

private:
  struct Node {
    Eigen::Vector3d min, max;
    std::uint32_t first = 0, count = 0; ///< leaf: primitives [first, first + count)
    std::uint32_t left = 0, right = 0;  ///< inner node (count == 0): children
  };
  struct Ref {
    std::uint8_t type;
    std::uint32_t index;
  };
  std::uint32_t
  build(std::uint32_t first,
        std::uint32_t count,
        std::vector<Eigen::Vector3d>& lo,
        std::vector<Eigen::Vector3d>& hi);

  World world_;
  std::vector<Ref> refs_;
  std::vector<Node> nodes_;
};

} // namespace sim
} // namespace pcl_parallel

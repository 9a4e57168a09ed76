/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/sim/scene.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace pcl_parallel {
namespace sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

enum : std::uint8_t { kBox, kCylinder, kOrientedBox, kTriangle };

/** Entry and exit distances of a ray through the box [lo, hi] (slab test). */
bool
slabs(const Eigen::Vector3d& lo,
      const Eigen::Vector3d& hi,
      const Eigen::Vector3d& o,
      const Eigen::Vector3d& d,
      double& t_in,
      double& t_out)
{
  t_in = -kInf;
  t_out = kInf;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d(k)) < 1e-15) { // parallel to this slab: inside it or a miss
      if (o(k) < lo(k) || o(k) > hi(k))
        return false;
      continue;
    }
    double t1 = (lo(k) - o(k)) / d(k);
    double t2 = (hi(k) - o(k)) / d(k);
    if (t1 > t2)
      std::swap(t1, t2);
    t_in = std::max(t_in, t1);
    t_out = std::min(t_out, t2);
  }
  return t_in <= t_out;
}

/** First hit (> 0) of a ray with a solid box: the entry, or from inside the exit. */
double
solidHit(const Eigen::Vector3d& lo,
         const Eigen::Vector3d& hi,
         const Eigen::Vector3d& o,
         const Eigen::Vector3d& d)
{
  double t_in, t_out;
  if (!slabs(lo, hi, o, d, t_in, t_out))
    return kInf;
  const double t = t_in > 0.0 ? t_in : t_out;
  return t > 0.0 ? t : kInf;
}

double
hit(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d)
{
  return solidHit(b.min, b.max, o, d);
}

double
hit(const OrientedBox& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d)
{
  // In the box's frame it is an axis-aligned box; distances are kept by the rotation.
  return solidHit(-b.half_size,
                  b.half_size,
                  b.rotation.transpose() * (o - b.centre),
                  b.rotation.transpose() * d);
}

/** First hit (> 0) of a ray with a capped vertical cylinder. */
double
hit(const Cylinder& c, const Eigen::Vector3d& o, const Eigen::Vector3d& d)
{
  double t = kInf;
  const double ox = o.x() - c.x, oy = o.y() - c.y;
  const double a = d.x() * d.x() + d.y() * d.y();
  const double r2 = c.radius * c.radius;
  if (a > 1e-15) { // side
    const double b = ox * d.x() + oy * d.y();
    const double cc = ox * ox + oy * oy - r2;
    const double disc = b * b - a * cc;
    if (disc >= 0.0) {
      const double s = std::sqrt(disc);
      for (const double root : {(-b - s) / a, (-b + s) / a}) {
        const double z = o.z() + root * d.z();
        if (root > 0.0 && z >= c.z_min && z <= c.z_max) {
          t = std::min(t, root);
          break; // the nearer root first
        }
      }
    }
  }
  if (std::abs(d.z()) > 1e-15) // caps
    for (const double z : {c.z_min, c.z_max}) {
      const double root = (z - o.z()) / d.z();
      const double x = ox + root * d.x(), y = oy + root * d.y();
      if (root > 0.0 && x * x + y * y <= r2)
        t = std::min(t, root);
    }
  return t;
}

/** Möller and Trumbore (1997), two-sided. */
double
hit(const Triangle& tri, const Eigen::Vector3d& o, const Eigen::Vector3d& d)
{
  const Eigen::Vector3d e1 = tri.b - tri.a, e2 = tri.c - tri.a;
  const Eigen::Vector3d p = d.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-15)
    return kInf;
  const double inv = 1.0 / det;
  const Eigen::Vector3d s = o - tri.a;
  const double u = s.dot(p) * inv;
  if (u < 0.0 || u > 1.0)
    return kInf;
  const Eigen::Vector3d q = s.cross(e1);
  const double v = d.dot(q) * inv;
  if (v < 0.0 || u + v > 1.0)
    return kInf;
  const double t = e2.dot(q) * inv;
  return t > 0.0 ? t : kInf;
}

double
hit(const World& w,
    std::uint8_t type,
    std::uint32_t i,
    const Eigen::Vector3d& o,
    const Eigen::Vector3d& d)
{
  switch (type) {
  case kBox:
    return hit(w.boxes[i], o, d);
  case kCylinder:
    return hit(w.cylinders[i], o, d);
  case kOrientedBox:
    return hit(w.oriented_boxes[i], o, d);
  default:
    return hit(w.triangles[i], o, d);
  }
}

void
bounds(const World& w,
       std::uint8_t type,
       std::uint32_t i,
       Eigen::Vector3d& lo,
       Eigen::Vector3d& hi)
{
  switch (type) {
  case kBox:
    lo = w.boxes[i].min, hi = w.boxes[i].max;
    break;
  case kCylinder: {
    const Cylinder& c = w.cylinders[i];
    lo = {c.x - c.radius, c.y - c.radius, c.z_min};
    hi = {c.x + c.radius, c.y + c.radius, c.z_max};
    break;
  }
  case kOrientedBox: {
    const OrientedBox& b = w.oriented_boxes[i];
    const Eigen::Vector3d extent = b.rotation.cwiseAbs() * b.half_size;
    lo = b.centre - extent, hi = b.centre + extent;
    break;
  }
  default: {
    const Triangle& t = w.triangles[i];
    lo = t.a.cwiseMin(t.b).cwiseMin(t.c), hi = t.a.cwiseMax(t.b).cwiseMax(t.c);
  }
  }
  // Padding: rounding in the slab test never prunes a primitive on the node's face.
  const Eigen::Vector3d pad =
      Eigen::Vector3d::Constant(1e-6) + 1e-9 * lo.cwiseAbs().cwiseMax(hi.cwiseAbs());
  lo -= pad, hi += pad;
}

} // namespace

bool
World::raycast(const Eigen::Vector3d& origin,
               const Eigen::Vector3d& dir,
               double max_range,
               double& range) const
{
  range = kInf;
  for (const Box& b : boxes)
    range = std::min(range, hit(b, origin, dir));
  for (const Cylinder& c : cylinders)
    range = std::min(range, hit(c, origin, dir));
  for (const OrientedBox& b : oriented_boxes)
    range = std::min(range, hit(b, origin, dir));
  for (const Triangle& t : triangles)
    range = std::min(range, hit(t, origin, dir));
  return range <= max_range;
}

RayCaster::RayCaster(const World& world)
    : world_(world)
{
  const auto add = [this](std::uint8_t type, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i)
      refs_.push_back({type, static_cast<std::uint32_t>(i)});
  };
  add(kBox, world_.boxes.size());
  add(kCylinder, world_.cylinders.size());
  add(kOrientedBox, world_.oriented_boxes.size());
  add(kTriangle, world_.triangles.size());
  std::vector<Eigen::Vector3d> lo(refs_.size()), hi(refs_.size());
  for (std::size_t i = 0; i < refs_.size(); ++i)
    bounds(world_, refs_[i].type, refs_[i].index, lo[i], hi[i]);
  if (!refs_.empty())
    build(0, static_cast<std::uint32_t>(refs_.size()), lo, hi);
}

std::uint32_t
RayCaster::build(std::uint32_t first,
                 std::uint32_t count,
                 std::vector<Eigen::Vector3d>& lo,
                 std::vector<Eigen::Vector3d>& hi)
{
  const auto id = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();
  Node node;
  node.min = lo[first], node.max = hi[first];
  Eigen::Vector3d cmin = 0.5 * (lo[first] + hi[first]), cmax = cmin;
  for (std::uint32_t i = first; i < first + count; ++i) {
    node.min = node.min.cwiseMin(lo[i]), node.max = node.max.cwiseMax(hi[i]);
    const Eigen::Vector3d c = 0.5 * (lo[i] + hi[i]);
    cmin = cmin.cwiseMin(c), cmax = cmax.cwiseMax(c);
  }
  int axis;
  const double spread = (cmax - cmin).maxCoeff(&axis);
  if (count <= 4 || spread <= 0.0) {
    node.first = first, node.count = count;
    nodes_[id] = node;
    return id;
  }
  // Median split of the centroids along the widest axis (a permutation of refs, lo, hi).
  std::vector<std::uint32_t> order(count);
  std::iota(order.begin(), order.end(), first);
  const std::uint32_t half = count / 2;
  std::nth_element(order.begin(), order.begin() + half, order.end(), [&](auto a, auto b) {
    const double ca = lo[a](axis) + hi[a](axis), cb = lo[b](axis) + hi[b](axis);
    return ca < cb || (ca == cb && a < b);
  });
  std::vector<Ref> refs(count);
  std::vector<Eigen::Vector3d> l(count), h(count);
  for (std::uint32_t k = 0; k < count; ++k)
    refs[k] = refs_[order[k]], l[k] = lo[order[k]], h[k] = hi[order[k]];
  std::copy(refs.begin(), refs.end(), refs_.begin() + first);
  std::copy(l.begin(), l.end(), lo.begin() + first);
  std::copy(h.begin(), h.end(), hi.begin() + first);
  node.left = build(first, half, lo, hi);
  node.right = build(first + half, count - half, lo, hi);
  nodes_[id] = node;
  return id;
}

bool
RayCaster::raycast(const Eigen::Vector3d& origin,
                   const Eigen::Vector3d& dir,
                   double max_range,
                   double& range) const
{
  range = kInf;
  if (nodes_.empty())
    return false;
  double best = max_range; // nodes beyond max_range cannot give a return
  std::uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    double t_in, t_out;
    if (!slabs(n.min, n.max, origin, dir, t_in, t_out) || t_out < 0.0 || t_in > best)
      continue;
    if (n.count > 0) {
      for (std::uint32_t i = n.first; i < n.first + n.count; ++i)
        range = std::min(range, hit(world_, refs_[i].type, refs_[i].index, origin, dir));
      best = std::min(best, range);
      continue;
    }
    // Nearer child last on the stack: visited first, so it tightens `best` early.
    const Node& l = nodes_[n.left];
    const Node& r = nodes_[n.right];
    double tl_in, tl_out, tr_in, tr_out;
    const bool hl = slabs(l.min, l.max, origin, dir, tl_in, tl_out);
    const bool hr = slabs(r.min, r.max, origin, dir, tr_in, tr_out);
    if (hl && hr && tl_in < tr_in) {
      stack[top++] = n.right;
      stack[top++] = n.left;
    }
    else {
      if (hl)
        stack[top++] = n.left;
      if (hr)
        stack[top++] = n.right;
    }
  }
  return range <= max_range;
}

} // namespace sim
} // namespace pcl_parallel

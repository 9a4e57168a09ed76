/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/registration/correspondence_estimation.h> // sqrDistanceBound
#include <pcl_parallel/registration/lum.h>
#include <pcl_parallel/search/impl/kdtree.hpp>

#include <pcl/common/transforms.h>
#include <pcl/console/print.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>

namespace pcl_parallel {

template <typename PointT>
ParallelLUM<PointT>::ParallelLUM()
    : slam_graph_(new SLAMGraph)
{}

template <typename PointT>
ParallelLUM<PointT>::~ParallelLUM() = default;

template <typename PointT>
void
ParallelLUM<PointT>::setLoopGraph(const SLAMGraphPtr& slam_graph)
{
  if (!slam_graph)
    throw std::invalid_argument("[pcl_parallel::ParallelLUM::setLoopGraph] null graph");
  slam_graph_ = slam_graph;
  poses_.clear();
  mirrors_.clear();
  hints_.clear();
  constraints_.clear(); // they name the old graph's vertices
}

template <typename PointT>
typename ParallelLUM<PointT>::SLAMGraph::vertices_size_type
ParallelLUM<PointT>::getNumVertices() const
{
  return num_vertices(*slam_graph_);
}

template <typename PointT>
void
ParallelLUM<PointT>::checkVertex(const Vertex& v, const char* where) const
{
  if (v >= getNumVertices())
    throw std::out_of_range(std::string("[pcl_parallel::ParallelLUM::") + where + "] vertex " +
                            std::to_string(v) + " does not exist (" +
                            std::to_string(getNumVertices()) + " vertices)");
}

template <typename PointT>
void
ParallelLUM<PointT>::syncPoses()
{
  const std::size_t n = getNumVertices();
  poses_.resize(n, Eigen::Matrix4d::Identity());
  mirrors_.resize(n, Eigen::Vector6f::Constant(std::numeric_limits<float>::quiet_NaN()));
  for (std::size_t v = 0; v < n; ++v) {
    const Eigen::Vector6f& p = (*slam_graph_)[v].pose_;
    // Bitwise comparison: NaN mirrors (new vertices) never match.
    if (!(p.array() == mirrors_[v].array()).all()) {
      poses_[v] = poseToMatrix(p);
      mirrors_[v] = p;
    }
  }
}

template <typename PointT>
void
ParallelLUM<PointT>::writeBackPoses()
{
  for (std::size_t v = 0; v < poses_.size(); ++v) {
    mirrors_[v] = matrixToPose(poses_[v]);
    (*slam_graph_)[v].pose_ = mirrors_[v];
  }
}

template <typename PointT>
typename ParallelLUM<PointT>::Vertex
ParallelLUM<PointT>::addPointCloud(const PointCloudPtr& cloud, const Eigen::Vector6f& pose)
{
  syncPoses();
  const Vertex v = add_vertex(*slam_graph_);
  (*slam_graph_)[v].cloud_ = cloud;
  if (v == 0 && pose != Eigen::Vector6f::Zero())
    PCL_WARN("[pcl_parallel::ParallelLUM::addPointCloud] The pose estimate is ignored for "
             "the first cloud in the graph since that will become the reference pose.\n");
  (*slam_graph_)[v].pose_ = v == 0 ? Eigen::Vector6f::Zero() : pose;
  syncPoses();
  return v;
}

template <typename PointT>
typename ParallelLUM<PointT>::Vertex
ParallelLUM<PointT>::addPointCloud(const PointCloudPtr& cloud, const Eigen::Matrix4f& pose)
{
  syncPoses();
  const Vertex v = add_vertex(*slam_graph_);
  (*slam_graph_)[v].cloud_ = cloud;
  poses_.push_back(pose.cast<double>());
  mirrors_.push_back(matrixToPose(poses_.back()));
  (*slam_graph_)[v].pose_ = mirrors_.back();
  return v;
}

template <typename PointT>
void
ParallelLUM<PointT>::setPointCloud(const Vertex& vertex, const PointCloudPtr& cloud)
{
  checkVertex(vertex, "setPointCloud");
  (*slam_graph_)[vertex].cloud_ = cloud;
}

template <typename PointT>
typename ParallelLUM<PointT>::PointCloudPtr
ParallelLUM<PointT>::getPointCloud(const Vertex& vertex) const
{
  checkVertex(vertex, "getPointCloud");
  return (*slam_graph_)[vertex].cloud_;
}

template <typename PointT>
void
ParallelLUM<PointT>::setPose(const Vertex& vertex, const Eigen::Vector6f& pose)
{
  checkVertex(vertex, "setPose");
  if (vertex == 0) {
    PCL_ERROR("[pcl_parallel::ParallelLUM::setPose] The pose estimate is ignored for the "
              "first cloud in the graph since that will become the reference pose.\n");
    return;
  }
  syncPoses();
  (*slam_graph_)[vertex].pose_ = pose;
  syncPoses();
}

template <typename PointT>
Eigen::Vector6f
ParallelLUM<PointT>::getPose(const Vertex& vertex) const
{
  checkVertex(vertex, "getPose");
  return (*slam_graph_)[vertex].pose_;
}

template <typename PointT>
void
ParallelLUM<PointT>::setPoseMatrix(const Vertex& vertex, const Eigen::Matrix4d& pose)
{
  checkVertex(vertex, "setPoseMatrix");
  syncPoses();
  poses_[vertex] = pose;
  mirrors_[vertex] = matrixToPose(pose);
  (*slam_graph_)[vertex].pose_ = mirrors_[vertex];
}

template <typename PointT>
Eigen::Matrix4d
ParallelLUM<PointT>::getPoseMatrix(const Vertex& vertex) const
{
  checkVertex(vertex, "getPoseMatrix");
  const Eigen::Vector6f& p = (*slam_graph_)[vertex].pose_;
  if (vertex < poses_.size() && (p.array() == mirrors_[vertex].array()).all())
    return poses_[vertex];
  return poseToMatrix(p); // changed through the graph since
}

template <typename PointT>
Eigen::Affine3f
ParallelLUM<PointT>::getTransformation(const Vertex& vertex) const
{
  return Eigen::Affine3f(getPoseMatrix(vertex).template cast<float>());
}

template <typename PointT>
lum::Matrix6d
ParallelLUM<PointT>::getPoseCovariance(const Vertex& vertex) const
{
  checkVertex(vertex, "getPoseCovariance");
  return solver_->covariance(vertex);
}

namespace detail {
/** PCL's EdgeProperties leaves its matrices uninitialised. */
template <typename EdgeProperties>
EdgeProperties
zeroEdgeProperties()
{
  EdgeProperties ep;
  ep.cinv_.setZero();
  ep.cinvd_.setZero();
  return ep;
}
} // namespace detail

template <typename PointT>
void
ParallelLUM<PointT>::setCorrespondences(const Vertex& source_vertex,
                                        const Vertex& target_vertex,
                                        const pcl::CorrespondencesPtr& corrs)
{
  checkVertex(source_vertex, "setCorrespondences");
  checkVertex(target_vertex, "setCorrespondences");
  if (source_vertex == target_vertex)
    throw std::invalid_argument(
        "[pcl_parallel::ParallelLUM::setCorrespondences] source and target are the same");
  Edge e;
  bool present;
  std::tie(e, present) = edge(source_vertex, target_vertex, *slam_graph_);
  if (!present)
    std::tie(e, present) = add_edge(source_vertex,
                                    target_vertex,
                                    detail::zeroEdgeProperties<EdgeProperties>(),
                                    *slam_graph_);
  (*slam_graph_)[e].corrs_ = corrs;
}

template <typename PointT>
void
ParallelLUM<PointT>::addLink(const Vertex& source_vertex, const Vertex& target_vertex)
{
  checkVertex(source_vertex, "addLink");
  checkVertex(target_vertex, "addLink");
  if (source_vertex == target_vertex)
    throw std::invalid_argument("[pcl_parallel::ParallelLUM::addLink] source == target");
  if (!edge(source_vertex, target_vertex, *slam_graph_).second) {
    EdgeProperties ep = detail::zeroEdgeProperties<EdgeProperties>();
    ep.corrs_.reset(new pcl::Correspondences);
    add_edge(source_vertex, target_vertex, ep, *slam_graph_);
  }
}

template <typename PointT>
void
ParallelLUM<PointT>::addPoseConstraint(const Vertex& source_vertex,
                                       const Vertex& target_vertex,
                                       const Eigen::Matrix4d& relative,
                                       const lum::Matrix6d& information,
                                       double cauchy_scale)
{
  checkVertex(source_vertex, "addPoseConstraint");
  checkVertex(target_vertex, "addPoseConstraint");
  if (source_vertex == target_vertex)
    throw std::invalid_argument("[pcl_parallel::ParallelLUM::addPoseConstraint] source == "
                                "target");
  if (!relative.allFinite() || !information.allFinite() ||
      !information.isApprox(information.transpose(), 1e-9) || !(cauchy_scale >= 0.0) ||
      !std::isfinite(cauchy_scale))
    throw std::invalid_argument("[pcl_parallel::ParallelLUM::addPoseConstraint] the "
                                "relative pose or the information is not finite, the "
                                "information is not symmetric or the scale is negative");
  lum::PoseConstraint c;
  c.source = static_cast<std::uint32_t>(source_vertex);
  c.target = static_cast<std::uint32_t>(target_vertex);
  c.measured = relative;
  c.information = information;
  c.cauchy_scale = cauchy_scale;
  constraints_.push_back(c);
}

template <typename PointT>
double
ParallelLUM<PointT>::getPoseConstraintChi2(std::size_t k) const
{
  const lum::PoseConstraint& c = constraints_.at(k);
  return lum::constraintChi2(c, getPoseMatrix(c.source), getPoseMatrix(c.target));
}

template <typename PointT>
pcl::CorrespondencesPtr
ParallelLUM<PointT>::getCorrespondences(const Vertex& source_vertex,
                                        const Vertex& target_vertex) const
{
  checkVertex(source_vertex, "getCorrespondences");
  checkVertex(target_vertex, "getCorrespondences");
  const auto e = edge(source_vertex, target_vertex, *slam_graph_);
  if (!e.second) {
    PCL_ERROR("[pcl_parallel::ParallelLUM::getCorrespondences] There is no link %zu -> "
              "%zu.\n",
              static_cast<std::size_t>(source_vertex),
              static_cast<std::size_t>(target_vertex));
    return pcl::CorrespondencesPtr();
  }
  return (*slam_graph_)[e.first].corrs_;
}

template <typename PointT>
void
ParallelLUM<PointT>::setCorrespondenceDistance(double distance)
{
  if (!std::isfinite(distance))
    throw std::invalid_argument(
        "[pcl_parallel::ParallelLUM::setCorrespondenceDistance] distance must be finite");
  if (distance <= 0.0) { // PCL mode: fixed correspondences
    correspondence_distance_ = final_correspondence_distance_ = 0.0;
    correspondence_distance_factor_ = 1.0;
    return;
  }
  setCorrespondenceDistanceSchedule(distance, distance, 1.0);
}

template <typename PointT>
void
ParallelLUM<PointT>::setCorrespondenceDistanceSchedule(double initial_distance,
                                                       double final_distance,
                                                       double factor)
{
  // Negated comparisons so that NaN fails them too.
  if (!(final_distance > 0.0) || !(initial_distance >= final_distance) ||
      !std::isfinite(initial_distance) || !(factor > 0.0 && factor <= 1.0))
    throw std::invalid_argument(
        "[pcl_parallel::ParallelLUM::setCorrespondenceDistanceSchedule] needs "
        "initial_distance >= final_distance > 0 and 0 < factor <= 1");
  correspondence_distance_ = initial_distance;
  final_correspondence_distance_ = final_distance;
  correspondence_distance_factor_ = factor;
}

template <typename PointT>
double
ParallelLUM<PointT>::correspondenceDistanceAt(int k) const
{
  return std::max(final_correspondence_distance_,
                  correspondence_distance_ *
                      std::pow(correspondence_distance_factor_, std::max(k, 0)));
}

template <typename PointT>
void
ParallelLUM<PointT>::setPointToPointWeight(double weight)
{
  if (!(weight >= 0.0) || !std::isfinite(weight))
    throw std::invalid_argument(
        "[pcl_parallel::ParallelLUM::setPointToPointWeight] weight must be finite and >= 0");
  point_to_point_weight_ = weight;
}

template <typename PointT>
void
ParallelLUM<PointT>::setNormalNeighbours(std::size_t k)
{
  if (k < 3)
    throw std::invalid_argument(
        "[pcl_parallel::ParallelLUM::setNormalNeighbours] a normal needs k >= 3 neighbours");
  normal_neighbours_ = k;
}

template <typename PointT>
std::vector<Eigen::Vector3f>
ParallelLUM<PointT>::getPointNormals(const Vertex& vertex) const
{
  checkVertex(vertex, "getPointNormals");
  if (vertex < given_normals_.size() && !given_normals_[vertex].empty())
    return given_normals_[vertex];
  std::vector<Eigen::Vector3f> normals;
  if (vertex >= trees_.size() || !trees_[vertex] || vertex >= normals_.size() ||
      normals_[vertex].size() != trees_[vertex]->size())
    return normals;
  const KdTreeIndex& tree = *trees_[vertex]; // tree positions back to point indices
  normals.resize(tree_source_[vertex].second, Eigen::Vector3f::Zero());
  for (std::uint32_t pos = 0; pos < tree.size(); ++pos)
    normals[tree.id(pos)] = normals_[vertex][pos];
  return normals;
}

template <typename PointT>
void
ParallelLUM<PointT>::setPointNormals(const Vertex& vertex, std::vector<Eigen::Vector3f> normals)
{
  checkVertex(vertex, "setPointNormals");
  const PointCloudPtr& cloud = (*slam_graph_)[vertex].cloud_;
  if (!normals.empty() && (!cloud || normals.size() != cloud->size()))
    throw std::invalid_argument("[pcl_parallel::ParallelLUM::setPointNormals] " +
                                std::to_string(normals.size()) + " normals for a cloud of " +
                                std::to_string(cloud ? cloud->size() : 0) + " points");
  given_normals_.resize(getNumVertices());
  normals_k_.resize(getNumVertices(), 0);
  given_normals_[vertex] = std::move(normals);
  normals_k_[vertex] = 0; // mapped to tree positions (or estimated) by buildTrees
}

template <typename PointT>
void
ParallelLUM<PointT>::setSearchTree(const Vertex& vertex,
                                   std::shared_ptr<const KdTreeIndex> tree)
{
  checkVertex(vertex, "setSearchTree");
  const PointCloud* cloud = (*slam_graph_)[vertex].cloud_.get();
  search::detail::checkIndexFits(
      cloud, tree.get(), "[pcl_parallel::ParallelLUM::setSearchTree] ");
  resizeVertexState();
  trees_[vertex] = std::move(tree);
  tree_source_[vertex] = {cloud, cloud->size()};
  normals_k_[vertex] = 0; // normals by tree position: mapped from given ones, or anew
}

template <typename PointT>
void
ParallelLUM<PointT>::setLinkIterations(int iterations)
{
  if (iterations < 1)
    throw std::invalid_argument(
        "[pcl_parallel::ParallelLUM::setLinkIterations] needs at least 1 iteration");
  link_iterations_ = iterations;
}

template <typename PointT>
std::vector<typename ParallelLUM<PointT>::LinkRef>
ParallelLUM<PointT>::collectLinks() const
{
  std::vector<LinkRef> links;
  typename SLAMGraph::edge_iterator e, e_end;
  for (std::tie(e, e_end) = edges(*slam_graph_); e != e_end; ++e)
    links.push_back({source(*e, *slam_graph_), target(*e, *slam_graph_), *e, 0});
  // Fixed order independent of the graph's edge lists: the assembly order.
  std::stable_sort(links.begin(), links.end(), [](const LinkRef& a, const LinkRef& b) {
    return std::make_pair(a.source, a.target) < std::make_pair(b.source, b.target);
  });
  for (std::size_t i = 1; i < links.size(); ++i)
    if (links[i].source == links[i - 1].source && links[i].target == links[i - 1].target)
      links[i].duplicate = links[i - 1].duplicate + 1;
  return links;
}

template <typename PointT>
void
ParallelLUM<PointT>::validate(const std::vector<LinkRef>& links,
                              const std::vector<std::size_t>& mine) const
{
  const std::size_t n = getNumVertices();
  const std::string where = "[pcl_parallel::ParallelLUM::compute] ";
  if (n < 2)
    throw std::invalid_argument(where + "the graph needs at least 2 vertices");
  if (links.empty() && constraints_.empty())
    throw std::invalid_argument(where + "the graph has no links");
  std::vector<char> needed(n, mine.size() == links.size()), measured(links.size(), 0);
  for (const std::size_t li : mine) {
    needed[links[li].source] = needed[links[li].target] = 1;
    measured[li] = 1;
  }
  for (std::size_t v = 0; v < n; ++v) {
    const auto& cloud = (*slam_graph_)[v].cloud_;
    if (needed[v] && (!cloud || cloud->empty()))
      throw std::invalid_argument(where + "vertex " + std::to_string(v) +
                                  " has no or an empty point cloud");
    if (!poses_[v].allFinite())
      throw std::invalid_argument(where + "vertex " + std::to_string(v) +
                                  " has a non-finite pose");
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (std::size_t li = 0; li < links.size(); ++li) {
    const LinkRef& l = links[li];
    pairs.emplace_back(static_cast<std::uint32_t>(l.source),
                       static_cast<std::uint32_t>(l.target));
    if (correspondence_distance_ > 0.0 || !measured[li])
      continue;
    const auto& corrs = (*slam_graph_)[l.edge].corrs_;
    const std::string name =
        "link " + std::to_string(l.source) + " -> " + std::to_string(l.target);
    if (!corrs)
      throw std::invalid_argument(where + name +
                                  " has no correspondences (set them, or use pLUM mode "
                                  "with setCorrespondenceDistance)");
    const std::size_t ns = (*slam_graph_)[l.source].cloud_->size();
    const std::size_t nt = (*slam_graph_)[l.target].cloud_->size();
    for (const pcl::Correspondence& c : *corrs)
      if (c.index_query < 0 || static_cast<std::size_t>(c.index_query) >= ns ||
          c.index_match < 0 || static_cast<std::size_t>(c.index_match) >= nt)
        throw std::out_of_range(where + name + " has a correspondence index out of range");
  }
  for (const lum::PoseConstraint& c : constraints_)
    pairs.emplace_back(c.source, c.target);
  const auto unreachable = lum::unreachableFromZero(n, pairs);
  if (!unreachable.empty())
    throw std::invalid_argument(where + std::to_string(unreachable.size()) +
                                " vertices (first: " + std::to_string(unreachable.front()) +
                                ") are not connected to vertex 0 by any link");
}

template <typename PointT>
void
ParallelLUM<PointT>::resizeVertexState()
{
  const std::size_t n = getNumVertices();
  trees_.resize(n);
  tree_source_.resize(n, {nullptr, 0});
  normals_.resize(n);
  normals_k_.resize(n, 0);
}

template <typename PointT>
void
ParallelLUM<PointT>::buildTrees(const std::vector<char>* needed)
{
  const std::size_t n = getNumVertices();
  resizeVertexState();
  std::vector<std::size_t> todo;
  for (std::size_t v = 0; v < n; ++v) {
    const PointCloud* c = (*slam_graph_)[v].cloud_.get();
    const std::size_t size = c ? c->size() : 0;
    if (!c) { // none here (another process keeps it), or released: no tree
      trees_[v].reset();
      tree_source_[v] = {nullptr, 0};
      continue;
    }
    if (needed && !(*needed)[v])
      continue;
    if (!trees_[v] || tree_source_[v] != std::make_pair(c, size))
      todo.push_back(v);
  }
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  // One tree per thread at a time; a tree does not depend on how it was built.
  parallelFor(todo.size(), threads, 1, [&](std::size_t first, std::size_t last) {
    for (std::size_t k = first; k < last; ++k) {
      const std::size_t v = todo[k];
      auto tree = std::make_shared<KdTreeIndex>();
      search::detail::buildIndex(
          *tree, (*slam_graph_)[v].cloud_.get(), nullptr, 1, KdTreeIndex::kDefaultBucketSize);
      trees_[v] = tree;
      const PointCloud* c = (*slam_graph_)[v].cloud_.get();
      tree_source_[v] = {c, c ? c->size() : 0};
      normals_k_[v] = 0;
    }
  });
  if (!point_to_plane_)
    return;
  given_normals_.resize(n);
  for (std::size_t v = 0; v < n; ++v) {
    if (!trees_[v])
      continue;
    std::vector<Eigen::Vector3f>& given = given_normals_[v];
    if (!given.empty()) { // by tree position (the tree reorders points), then released
      const KdTreeIndex& tree = *trees_[v];
      if (given.size() == tree_source_[v].second) { // else the cloud changed: estimate
        normals_[v].resize(tree.size());
        for (std::uint32_t pos = 0; pos < tree.size(); ++pos)
          normals_[v][pos] = given[tree.id(pos)];
        normals_k_[v] = kGivenNormals;
      }
      std::vector<Eigen::Vector3f>().swap(given);
    }
    if (normals_k_[v] != kGivenNormals && normals_k_[v] != normal_neighbours_) {
      normals_[v] = planar_
                        ? estimateUnitNormals(
                              *trees_[v], normal_neighbours_, threads, Eigen::Vector3f::UnitZ())
                        : estimateUnitNormals(*trees_[v], normal_neighbours_, threads);
      normals_k_[v] = normal_neighbours_;
    }
  }
}

template <typename PointT>
void
ParallelLUM<PointT>::computeLinkPairs(const LinkRef& link,
                                      double max_distance,
                                      const Eigen::Matrix4d& motion,
                                      ThreadState& state,
                                      lum::LinkAccumulator& acc,
                                      pcl::Correspondences* out)
{
  if (out)
    out->clear();
  const float max_sqr = registration::sqrDistanceBound(max_distance);
  const double plane_lambda = point_to_point_weight_;
  NearestSlot& slot = state.slot;
  float* q = state.query;
  slot.query = q;
  const Eigen::Matrix4d source_pose = motion * poses_[link.source];
  // Pass 0: source points searched in the target's tree; pass 1 (symmetric mode): the
  // reverse. Both feed one accumulator with the residual always source - target, so
  // overlap borders pull from both sides and the bias of one-sided pairing cancels.
  for (int pass = 0; pass < (symmetric_ ? 2 : 1); ++pass) {
    const Vertex from = pass == 0 ? link.source : link.target;
    const Vertex to = pass == 0 ? link.target : link.source;
    const PointCloud& cloud = *(*slam_graph_)[from].cloud_;
    const KdTreeIndex& tree = *trees_[to];
    const Eigen::Matrix4d& t_from = pass == 0 ? source_pose : poses_[from];
    const Eigen::Matrix4d& t_to = pass == 0 ? poses_[to] : source_pose;
    const std::vector<Eigen::Vector3f>* normals = point_to_plane_ ? &normals_[to] : nullptr;
    // Query points into the other scan's own frame, where its tree was built.
    const Eigen::Matrix4f rel = (t_to.inverse() * t_from).template cast<float>();
    std::vector<std::uint32_t>& hints =
        hints_.at(HintKey(link.source, link.target, link.duplicate, pass));
    if (hints.size() != cloud.size())
      hints.assign(cloud.size(), KdTreeIndex::kInvalid);
    for (std::size_t k = 0; k < cloud.size(); k += query_step_) {
      const Eigen::Vector3f p = cloud[k].getVector3fMap();
      if (!p.allFinite())
        continue;
      Eigen::Vector3f::Map(q) = rel.topLeftCorner<3, 3>() * p + rel.topRightCorner<3, 1>();
      const std::uint32_t pos = tree.nearest(slot, max_sqr, hints[k]);
      hints[k] = pos;
      if (pos == KdTreeIndex::kInvalid)
        continue;
      const Eigen::Vector3d a =
          t_from.topLeftCorner<3, 3>() * p.cast<double>() + t_from.topRightCorner<3, 1>();
      const Eigen::Vector3d b =
          t_to.topLeftCorner<3, 3>() *
              Eigen::Vector3f::Map(tree.point(pos)).template cast<double>() +
          t_to.topRightCorner<3, 1>();
      const Eigen::Vector3d& src = pass == 0 ? a : b;
      const Eigen::Vector3d& tgt = pass == 0 ? b : a;
      if (normals) {
        // The matched point's normal, in the world frame.
        const Eigen::Vector3d n =
            t_to.topLeftCorner<3, 3>() * (*normals)[pos].template cast<double>();
        Eigen::Matrix3d w = n * n.transpose();
        w.diagonal().array() += plane_lambda;
        acc.addWeighted(src, tgt, w);
      }
      else
        acc.add(src, tgt);
      if (pass == 0 && out)
        out->emplace_back(static_cast<pcl::index_t>(k),
                          static_cast<pcl::index_t>(tree.id(pos)),
                          slot.sqr_dist);
    }
  }
}

template <typename PointT>
bool
ParallelLUM<PointT>::measureLink(const LinkRef& link,
                                 double max_distance,
                                 ThreadState& state,
                                 lum::LinkBlock& block,
                                 pcl::Correspondences* out,
                                 std::size_t& num_pairs,
                                 const char** reason)
{
  // Pairwise ICP on the link: the source scan moves by `motion` on top of its pose.
  Eigen::Matrix4d motion = Eigen::Matrix4d::Identity();
  lum::LinkAccumulator acc;
  for (int step = 0;; ++step) {
    acc = lum::LinkAccumulator();
    computeLinkPairs(link, max_distance, motion, state, acc, out);
    if (step + 1 >= link_iterations_)
      break;
    lum::Vector6d d;
    // Converged (another pairing would find the same pairs): acc's own measurement is
    // the remaining step, so it is not also folded into the motion.
    if (!acc.measurement(min_correspondences_, d) || d.norm() < 1e-9)
      break; // on failure, finish() below reports why
    const Eigen::Matrix4d& pose = poses_[link.source];
    Eigen::Matrix4d moved = motion * pose;
    lum::applyUpdate(moved, d);
    motion = moved * pose.inverse();
  }
  num_pairs = acc.size();
  if (!acc.finish(min_correspondences_, 1e-12, block.info, block.grad, nullptr, reason))
    return false;
  if (link_iterations_ > 1) {
    // D-bar = the pairwise motion so far plus the last step's: g = -H (D_motion + D_last)
    // = g_last - H D_motion.
    const lum::Vector6d d_motion =
        lum::updateBetween(poses_[link.source], motion * poses_[link.source]);
    block.grad -= block.info * d_motion;
  }
  return true;
}

template <typename PointT>
void
ParallelLUM<PointT>::computeLinkFixed(const LinkRef& link, lum::LinkAccumulator& acc) const
{
  const PointCloud& src = *(*slam_graph_)[link.source].cloud_;
  const PointCloud& tgt = *(*slam_graph_)[link.target].cloud_;
  const Eigen::Matrix4d& ti = poses_[link.source];
  const Eigen::Matrix4d& tj = poses_[link.target];
  for (const pcl::Correspondence& c : *(*slam_graph_)[link.edge].corrs_) {
    const Eigen::Vector3d p = src[c.index_query].getVector3fMap().template cast<double>();
    const Eigen::Vector3d q = tgt[c.index_match].getVector3fMap().template cast<double>();
    if (!p.allFinite() || !q.allFinite())
      continue;
    acc.add(ti.topLeftCorner<3, 3>() * p + ti.topRightCorner<3, 1>(),
            tj.topLeftCorner<3, 3>() * q + tj.topRightCorner<3, 1>());
  }
}

template <typename PointT>
void
ParallelLUM<PointT>::beginCompute(Run& run, const LinkSelection& select)
{
  syncPoses();
  run.links = collectLinks();
  if (select)
    run.mine = select(run.links);
  else {
    run.mine.resize(run.links.size());
    std::iota(run.mine.begin(), run.mine.end(), std::size_t(0));
  }
  validate(run.links, run.mine);
  run.plum = correspondence_distance_ > 0.0;
  run.threads = resolveNumberOfThreads(num_threads_);
  if (run.plum) {
    if (run.mine.size() == run.links.size())
      buildTrees();
    else {
      std::vector<char> needed(getNumVertices(), 0);
      for (const std::size_t li : run.mine)
        needed[run.links[li].source] = needed[run.links[li].target] = 1;
      buildTrees(&needed);
    }
    for (const LinkRef& l : run.links) // create before the parallel loop: no insertion races
      for (int pass = 0; pass < 2; ++pass)
        hints_[HintKey(l.source, l.target, l.duplicate, pass)];
  }
  const std::size_t num_links = run.links.size();
  run.blocks.assign(num_links, lum::LinkBlock());
  run.reasons.assign(num_links, nullptr);
  run.pair_counts.assign(num_links, 0);
  run.link_corrs.assign(num_links, nullptr);
  run.states = std::vector<ThreadState>(run.threads);
  iterations_done_ = 0;
}

template <typename PointT>
void
ParallelLUM<PointT>::measureLinks(Run& run, int it)
{
  const double gate = correspondenceDistanceAt(it);
  const unsigned threads = run.threads;
  // Steps 1-2 for the links in parallel; each link's sums run in a fixed order.
  parallelFor(
      run.mine.size(), threads, 1, [&](std::size_t first, std::size_t last, unsigned t) {
        for (std::size_t k = first; k < last; ++k) {
          const std::size_t li = run.mine[k];
          const LinkRef& link = run.links[li];
          lum::LinkBlock& b = run.blocks[li];
          b.source = static_cast<std::uint32_t>(link.source);
          b.target = static_cast<std::uint32_t>(link.target);
          if (run.plum) {
            if (!run.link_corrs[li])
              run.link_corrs[li].reset(new pcl::Correspondences);
            b.valid = measureLink(link,
                                  gate,
                                  run.states[t],
                                  b,
                                  run.link_corrs[li].get(),
                                  run.pair_counts[li],
                                  &run.reasons[li]);
            continue;
          }
          lum::LinkAccumulator acc;
          computeLinkFixed(link, acc);
          run.pair_counts[li] = acc.size();
          b.valid = acc.finish(
              min_correspondences_, 1e-12, b.info, b.grad, nullptr, &run.reasons[li]);
        }
      });
}

template <typename PointT>
bool
ParallelLUM<PointT>::solveIteration(Run& run, int it)
{
  const std::size_t n = getNumVertices();
  const std::vector<LinkRef>& links = run.links;
  dropped_links_ = 0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> valid;
  for (std::size_t li = 0; li < links.size(); ++li) {
    if (run.blocks[li].valid) {
      valid.emplace_back(run.blocks[li].source, run.blocks[li].target);
      continue;
    }
    ++dropped_links_;
    PCL_WARN("[pcl_parallel::ParallelLUM::compute] Link %zu -> %zu dropped in iteration "
             "%d: %s (%zu pairs).\n",
             static_cast<std::size_t>(links[li].source),
             static_cast<std::size_t>(links[li].target),
             it,
             run.reasons[li] ? run.reasons[li] : "invalid",
             run.pair_counts[li]);
  }
  // The pose constraints after the links, in the order added (deterministic).
  run.blocks.resize(links.size());
  // A constraint's robust kernel looks at the link between its vertices (constraintBlock).
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t> link_of;
  for (std::size_t li = 0; li < links.size(); ++li)
    if (run.blocks[li].valid)
      link_of.emplace(std::make_pair(run.blocks[li].source, run.blocks[li].target), li);
  for (const lum::PoseConstraint& c : constraints_) {
    const auto f = link_of.find({c.source, c.target});
    const lum::LinkBlock* link = f == link_of.end() ? nullptr : &run.blocks[f->second];
    run.blocks.push_back(lum::constraintBlock(c, poses_[c.source], poses_[c.target], link));
    if (run.blocks.back().valid)
      valid.emplace_back(c.source, c.target);
  }
  const auto unreachable = lum::unreachableFromZero(n, valid);
  if (!unreachable.empty()) {
    PCL_ERROR("[pcl_parallel::ParallelLUM::compute] After dropping links, %zu vertices "
              "(first: %u) are not connected to vertex 0; stopping with the poses of "
              "iteration %d.\n",
              unreachable.size(),
              unreachable.front(),
              it);
    return false;
  }
  // Steps 3-4.
  solver_->setPlanar(planar_);
  if (!solver_->solve(n, run.blocks, run.delta)) {
    PCL_ERROR("[pcl_parallel::ParallelLUM::compute] The linear system G X = B could not "
              "be solved in iteration %d; poses left unchanged.\n",
              it);
    return false;
  }
  // Step 5.
  double sum = 0.0;
  for (std::size_t v = 1; v < n; ++v) {
    lum::applyUpdate(poses_[v], run.delta[v]);
    sum += run.delta[v].norm();
  }
  ++iterations_done_;
  last_mean_update_ = sum / static_cast<double>(n - 1);
  if (iteration_callback_) {
    writeBackPoses();
    iteration_callback_(it, last_mean_update_);
  }
  // A shrinking gate must reach its end before convergence counts.
  return !(last_mean_update_ <= convergence_threshold_ &&
           (!run.plum || correspondenceDistanceAt(it) <= final_correspondence_distance_));
}

template <typename PointT>
void
ParallelLUM<PointT>::endCompute(Run& run)
{
  writeBackPoses();
  for (std::size_t li = 0; li < run.links.size(); ++li) {
    EdgeProperties& ep = (*slam_graph_)[run.links[li].edge];
    ep.cinv_ = run.blocks[li].info.template cast<float>();
    ep.cinvd_ = run.blocks[li].grad.template cast<float>();
    if (run.plum && run.link_corrs[li])
      ep.corrs_ = run.link_corrs[li];
  }
}

template <typename PointT>
void
ParallelLUM<PointT>::compute()
{
  Run run;
  beginCompute(run);
  for (int it = 0; it < max_iterations_; ++it) {
    measureLinks(run, it);
    if (!solveIteration(run, it))
      break;
  }
  endCompute(run);
}

template <typename PointT>
typename ParallelLUM<PointT>::PointCloudPtr
ParallelLUM<PointT>::getTransformedCloud(const Vertex& vertex) const
{
  PointCloudPtr out(new PointCloud);
  pcl::transformPointCloud(*getPointCloud(vertex), *out, getPoseMatrix(vertex));
  return out;
}

template <typename PointT>
typename ParallelLUM<PointT>::PointCloudPtr
ParallelLUM<PointT>::getConcatenatedCloud() const
{
  PointCloudPtr out(new PointCloud);
  for (std::size_t v = 0; v < getNumVertices(); ++v) {
    PointCloud temp;
    pcl::transformPointCloud(*getPointCloud(v), temp, getPoseMatrix(v));
    *out += temp;
  }
  return out;
}

template <typename PointT>
double
ParallelLUM<PointT>::computeOverlap(const Vertex& source_vertex,
                                    const Vertex& target_vertex,
                                    double max_distance)
{
  checkVertex(source_vertex, "computeOverlap");
  checkVertex(target_vertex, "computeOverlap");
  syncPoses();
  buildTrees();
  return overlap(source_vertex, target_vertex, max_distance);
}

template <typename PointT>
std::shared_ptr<const KdTreeIndex>
ParallelLUM<PointT>::getSearchTree(const Vertex& vertex)
{
  checkVertex(vertex, "getSearchTree");
  buildTrees();
  return trees_[vertex];
}

template <typename PointT>
double
ParallelLUM<PointT>::overlap(const Vertex& source_vertex,
                             const Vertex& target_vertex,
                             double max_distance) const
{
  const PointCloudPtr& src = (*slam_graph_)[source_vertex].cloud_;
  const KdTreeIndex& tree = *trees_[target_vertex];
  if (!src || src->empty() || tree.empty())
    return 0.0;
  const Eigen::Matrix4f tji =
      (poses_[target_vertex].inverse() * poses_[source_vertex]).template cast<float>();
  const float max_sqr = registration::sqrDistanceBound(max_distance);
  std::size_t finite = 0, hits = 0;
  NearestSlot slot;
  float q[3];
  slot.query = q;
  for (const PointT& pt : *src) {
    const Eigen::Vector3f p = pt.getVector3fMap();
    if (!p.allFinite())
      continue;
    ++finite;
    Eigen::Vector3f::Map(q) = tji.topLeftCorner<3, 3>() * p + tji.topRightCorner<3, 1>();
    if (tree.nearest(slot, max_sqr) != KdTreeIndex::kInvalid)
      ++hits;
  }
  return finite ? static_cast<double>(hits) / static_cast<double>(finite) : 0.0;
}

template <typename PointT>
std::vector<
    std::pair<typename ParallelLUM<PointT>::Vertex, typename ParallelLUM<PointT>::Vertex>>
ParallelLUM<PointT>::findOverlappingPairs(double max_distance, double min_fraction)
{
  syncPoses();
  buildTrees();
  const std::size_t n = getNumVertices();
  std::vector<std::pair<Vertex, Vertex>> pairs;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j)
      pairs.emplace_back(i, j);
  std::vector<char> keep(pairs.size(), 0);
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  parallelFor(pairs.size(), threads, 1, [&](std::size_t first, std::size_t last) {
    for (std::size_t k = first; k < last; ++k) {
      const auto [i, j] = pairs[k];
      const double o = std::min(overlap(i, j, max_distance), overlap(j, i, max_distance));
      keep[k] = o >= min_fraction;
    }
  });
  std::vector<std::pair<Vertex, Vertex>> out;
  for (std::size_t k = 0; k < pairs.size(); ++k)
    if (keep[k])
      out.push_back(pairs[k]);
  return out;
}

} // namespace pcl_parallel

#define PCL_INSTANTIATE_ParallelLUM(T) template class pcl_parallel::ParallelLUM<T>;

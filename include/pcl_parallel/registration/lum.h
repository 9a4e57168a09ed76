/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/registration/lum_link.h>
#include <pcl_parallel/registration/pose_graph_solver.h>

#include <pcl/correspondence.h>
#include <pcl/point_cloud.h>
#include <pcl/registration/lum.h>

#include <functional>
#include <map>
#include <memory>
#include <tuple>
#include <utility>
#include <vector>

namespace pcl_parallel {

namespace mpi {
template <typename PointT>
class DistributedLUM;
} // namespace mpi

/**
 * \brief pLUM: Lu/Milios style 6D GraphSLAM, parallel over the links of the graph
 * (Nüchter 2007, Sec. III and V), with the public API of pcl::registration::LUM.
 *
 * Two modes:
 * - PCL mode (default): compute() uses the correspondences given per link with
 *   setCorrespondences(), fixed over all iterations, exactly as pcl::registration::LUM.
 * - pLUM mode (setCorrespondenceDistance(d) with d > 0): every iteration recomputes the
 *   closest points of every link (i, j) within d (paper step 1). Each scan's k-d tree is
 *   built once in the scan's own frame; the source points are moved into the target's
 *   frame by the current poses and searched there, by default in both directions
 *   (setSymmetricCorrespondences). Links come from setCorrespondences() (the given pairs
 *   are then ignored), addLink(), slam::loopCandidates() (slam/loop_closure.h) or
 *   findOverlappingPairs(). The distance may shrink over the iterations
 *   (setCorrespondenceDistanceSchedule). Options beyond the paper, off by default:
 *   point-to-plane pairs (setPointToPlane) and several pairing steps per link and
 *   iteration (setLinkIterations); together they make the relaxation converge in a few
 *   iterations without first moving poses away from the truth (docs/design.md).
 *
 * Per iteration, for all links in parallel (OpenMP, dynamic schedule): pairs, then the
 * link's measurement and covariance (step 2, lum::LinkAccumulator). The per-link blocks
 * are then assembled in link order into a sparse G X = B and solved with a sparse LDL^T
 * in double (steps 3-4, lum::PoseGraphSolver), and the poses updated (step 5). Every
 * per-link sum runs sequentially in a fixed order, so the result is identical for any
 * thread count.
 *
 * Poses are kept internally as 4x4 matrices in double and linearised with a local
 * (world-frame) perturbation of each pose (lum::applyUpdate), so no orientation is special;
 * PCL's (x, y, z, roll, pitch, yaw) vectors are converted only at the API boundary. Near pitch
 * = +-90 deg the 6-vector is ambiguous, the matrix (getPoseMatrix) is not.
 *
 * Deviations from pcl::registration::LUM, all on invalid input or by design:
 * - invalid input (missing vertex, empty cloud, non-finite pose, no links, a vertex not
 *   connected to vertex 0, out-of-range correspondence indices) throws
 *   std::invalid_argument / std::out_of_range where PCL prints an error or crashes;
 *   an unsolvable system stops compute() with PCL_ERROR, keeping the last good poses;
 * - a link with too few pairs or a singular covariance is dropped for the iteration with
 *   a PCL_WARN (PCL keeps it with zero weight, which may leave G singular);
 * - the link covariance is s^2 A^-1 with the unbiased s^2 = SSR / (3N - 6) (Borrmann et
 *   al. 2008) where PCL uses SSR; both agree when every link has the same pair count;
 * - EdgeProperties::cinv_ / cinvd_ receive our H and g (see lum_link.h), in the local
 *   perturbation's parametrisation, not in PCL's Euler one.
 */
template <typename PointT>
class ParallelLUM {
public:
  /** Shared pointer, as PCL's. */
  using Ptr = pcl::shared_ptr<ParallelLUM<PointT>>;
  /** Shared pointer to const, as PCL's. */
  using ConstPtr = pcl::shared_ptr<const ParallelLUM<PointT>>;
  /** Scan cloud type. */
  using PointCloud = pcl::PointCloud<PointT>;
  /** Shared pointer to a scan cloud. */
  using PointCloudPtr = typename PointCloud::Ptr;
  /** Shared pointer to a const scan cloud. */
  using PointCloudConstPtr = typename PointCloud::ConstPtr;

  // PCL's own graph type, so setLoopGraph/getLoopGraph interoperate with LUM<PointT>.
  /** PCL's LUM, whose graph types this class shares. */
  using PclLUM = pcl::registration::LUM<PointT>;
  /** PCL's vertex properties (cloud, pose). */
  using VertexProperties = typename PclLUM::VertexProperties;
  /** PCL's edge properties (correspondences, information). */
  using EdgeProperties = typename PclLUM::EdgeProperties;
  /** PCL's SLAM graph (Boost adjacency list). */
  using SLAMGraph = typename PclLUM::SLAMGraph;
  /** Shared pointer to the graph. */
  using SLAMGraphPtr = typename PclLUM::SLAMGraphPtr;
  /** A vertex (scan) of the graph. */
  using Vertex = typename SLAMGraph::vertex_descriptor;
  /** An edge (link) of the graph. */
  using Edge = typename SLAMGraph::edge_descriptor;

  ParallelLUM();
  ~ParallelLUM();

  // ---- pcl::registration::LUM API ------------------------------------------------
  /** As PCL; also drops the pose constraints (addPoseConstraint), which name vertices of
   *  the graph it replaces. */
  void
  setLoopGraph(const SLAMGraphPtr& slam_graph);
  /** The SLAM graph, as PCL's. */
  SLAMGraphPtr
  getLoopGraph() const
  {
    return slam_graph_;
  }
  /** Number of vertices (scans). */
  typename SLAMGraph::vertices_size_type
  getNumVertices() const;
  /** Iteration cap of compute() (default 5, as PCL). */
  void
  setMaxIterations(int max_iterations)
  {
    max_iterations_ = max_iterations;
  }
  /** Iteration cap of compute(). */
  int
  getMaxIterations() const
  {
    return max_iterations_;
  }
  /** compute() stops when the mean norm of the vertices' 6D updates (t in metres, w in
   *  radians) is at or below this (PCL's criterion; default 0). */
  void
  setConvergenceThreshold(float convergence_threshold)
  {
    convergence_threshold_ = convergence_threshold;
  }
  /** Mean pose update below which compute() stops. */
  float
  getConvergenceThreshold() const
  {
    return convergence_threshold_;
  }
  /** Adds a scan with pose (x, y, z, roll, pitch, yaw). As PCL, the first vertex is the
   *  fixed reference and its pose is forced to zero. */
  Vertex
  addPointCloud(const PointCloudPtr& cloud,
                const Eigen::Vector6f& pose = Eigen::Vector6f::Zero());
  /** Sets the cloud of \a vertex, as PCL's. */
  void
  setPointCloud(const Vertex& vertex, const PointCloudPtr& cloud);
  /** The cloud of \a vertex. */
  PointCloudPtr
  getPointCloud(const Vertex& vertex) const;
  /** Sets the pose of \a vertex as PCL's (x, y, z, roll, pitch, yaw). */
  void
  setPose(const Vertex& vertex, const Eigen::Vector6f& pose);
  /** The pose of \a vertex as PCL's 6-vector. */
  Eigen::Vector6f
  getPose(const Vertex& vertex) const;
  /** The pose of \a vertex as a 4x4 float transform, as PCL's. */
  Eigen::Affine3f
  getTransformation(const Vertex& vertex) const;
  /** Adds (or replaces) link source -> target with pairs (index_query in source,
   *  index_match in target). Throws std::out_of_range for a missing vertex. */
  void
  setCorrespondences(const Vertex& source_vertex,
                     const Vertex& target_vertex,
                     const pcl::CorrespondencesPtr& corrs);
  /** The link's pairs: the given ones, or in pLUM mode those of the last iteration. */
  pcl::CorrespondencesPtr
  getCorrespondences(const Vertex& source_vertex, const Vertex& target_vertex) const;
  /** Runs up to getMaxIterations() iterations (see the class comment). */
  void
  compute();
  /** The cloud of \a vertex moved by its pose. */
  PointCloudPtr
  getTransformedCloud(const Vertex& vertex) const;
  /** All clouds moved by their poses, concatenated. */
  PointCloudPtr
  getConcatenatedCloud() const;

  // ---- GraphRegistration style and double-precision poses -------------------------
  /** Adds a scan with a 4x4 pose (pcl::registration::GraphRegistration's signature).
   *  Unlike the 6-vector overload, vertex 0 keeps the given pose (still fixed). */
  Vertex
  addPointCloud(const PointCloudPtr& cloud, const Eigen::Matrix4f& pose);
  /** Any Eigen expression (e.g. Matrix4f::Identity(), a Matrix4d): 4x4 goes to the matrix
   *  overload, 6x1 to the 6-vector one (otherwise the two overloads are ambiguous). */
  template <typename Derived>
  Vertex
  addPointCloud(const PointCloudPtr& cloud, const Eigen::MatrixBase<Derived>& pose)
  {
    if constexpr (Derived::RowsAtCompileTime == 4 && Derived::ColsAtCompileTime == 4)
      return addPointCloud(cloud, Eigen::Matrix4f(pose.template cast<float>()));
    else
      return addPointCloud(cloud, Eigen::Vector6f(pose.template cast<float>()));
  }
  /** Sets the pose of \a vertex as a 4x4 double transform. */
  void
  setPoseMatrix(const Vertex& vertex, const Eigen::Matrix4d& pose);
  /** The pose of \a vertex as a 4x4 double transform. */
  Eigen::Matrix4d
  getPoseMatrix(const Vertex& vertex) const;
  /** 6x6 marginal covariance of the vertex's last update (t, w), from the last solve's
   *  factorisation (paper step 5); zero for vertex 0 or before compute(). */
  lum::Matrix6d
  getPoseCovariance(const Vertex& vertex) const;

  // ---- pLUM ------------------------------------------------------------------------
  /** > 0 turns on pLUM mode: pairs re-estimated every iteration within this distance
   *  (metres); 0 or less (default 0) uses the fixed correspondences. The same distance
   *  in every iteration (see setCorrespondenceDistanceSchedule). Throws
   *  std::invalid_argument for a non-finite distance. */
  void
  setCorrespondenceDistance(double distance);
  /** The distance of the first iteration (0: fixed correspondences). */
  double
  getCorrespondenceDistance() const
  {
    return correspondence_distance_;
  }
  /** pLUM mode with a shrinking gate: iteration k of compute() pairs within
   *  max(final_distance, initial_distance * factor^k). A wide gate first pulls large pose
   *  errors in; a tight one at the end keeps pairs from the borders of the overlap and
   *  from sampling offsets out of the fixed point (measured on the bunny in
   *  docs/design.md). compute() only stops on the convergence threshold once the gate
   *  has reached final_distance. Throws std::invalid_argument unless
   *  initial_distance >= final_distance > 0 and 0 < factor <= 1. */
  void
  setCorrespondenceDistanceSchedule(double initial_distance,
                                    double final_distance,
                                    double factor);
  /** The gate a distance schedule shrinks to. */
  double
  getFinalCorrespondenceDistance() const
  {
    return final_correspondence_distance_;
  }
  /** The factor per iteration of the distance schedule. */
  double
  getCorrespondenceDistanceFactor() const
  {
    return correspondence_distance_factor_;
  }
  /** The pair distance iteration k (from 0) of compute() uses. */
  double
  correspondenceDistanceAt(int k) const;

  /** pLUM mode: point-to-plane pairs (default false: the paper's point-to-point). Each
   *  pair's residual is weighted by W = n n^T + w I, n the normal of the matched point
   *  (from its scan's k nearest neighbours, estimated once per scan in its own frame),
   *  w = getPointToPointWeight(). Sliding along a surface then costs (almost) nothing,
   *  so a pair's offset along the surface from sampling no longer drags the poses; the
   *  small point-to-point share keeps a link well posed where its overlap is planar. */
  void
  setPointToPlane(bool point_to_plane)
  {
    point_to_plane_ = point_to_plane;
  }
  /** True when pairs are weighted by their normals (setPointToPlane). */
  bool
  getPointToPlane() const
  {
    return point_to_plane_;
  }
  /** The paper's 2D special case (Sec. VII): every pose update is a motion in the x-y
   *  plane (x, y and the yaw; G X = B reduced to those rows), for scans in that plane and
   *  planar poses, whose z, roll and pitch then stay as they are. Point-to-plane normals
   *  it estimates lie in the plane (normal to a wall's line). */
  void
  setPlanar(bool planar)
  {
    if (planar != planar_) // estimated normals are of the other kind
      for (std::size_t& k : normals_k_)
        k = k == kGivenNormals ? k : 0;
    planar_ = planar;
  }
  /** True when the updates are planar (setPlanar). */
  bool
  getPlanar() const
  {
    return planar_;
  }
  /** Weight w of the point-to-point term in point-to-plane mode (default 0.01, >= 0). */
  void
  setPointToPointWeight(double weight);
  /** Point-to-point weight w in n nᵀ + w I. */
  double
  getPointToPointWeight() const
  {
    return point_to_point_weight_;
  }
  /** Neighbours per normal in point-to-plane mode (default 10, >= 3). */
  void
  setNormalNeighbours(std::size_t k);
  /** Neighbours per estimated normal. */
  std::size_t
  getNormalNeighbours() const
  {
    return normal_neighbours_;
  }
  /** Point-to-plane mode: a vertex's normals given rather than estimated, one per point
   *  of its cloud in the cloud's frame (unit length, or zero where a point has none), for
   *  a caller that has them already (the pipeline's front end estimates them once per
   *  scan with the same estimator).
   *  They hold until the cloud changes; empty returns to estimating. Throws
   *  std::invalid_argument for a size other than the cloud's. */
  void
  setPointNormals(const Vertex& vertex, std::vector<Eigen::Vector3f> normals);
  /** Point-to-plane mode: the normals pLUM uses for a vertex's points, in the cloud's
   *  order (given, or estimated once its tree was built); empty if neither yet. Another
   *  process given them (setPointNormals) with the cloud pairs the vertex the same. */
  std::vector<Eigen::Vector3f>
  getPointNormals(const Vertex& vertex) const;
  /** pLUM mode: pairing steps per link and iteration (default 1, the paper's step 1).
   *  With k > 1 each link first aligns its two scans by up to k - 1 steps of pairwise
   *  ICP (re-pairing each time, poses of the graph unchanged), and its measurement D-bar
   *  is the whole pairwise motion plus the last step's, with the last pairs' covariance.
   *  This is Lu/Milios's original measurement (the result of matching the pair) rather
   *  than one linearisation step: on smooth surfaces one closest-point step sees only
   *  part of a pair's misalignment, and the graph then moves some poses away from the
   *  truth before it converges (docs/design.md). Costs up to k pairings per link. */
  void
  setLinkIterations(int iterations);
  /** Pairing steps per link and iteration (setLinkIterations). */
  int
  getLinkIterations() const
  {
    return link_iterations_;
  }
  /** Called after every iteration of compute() with the iteration's number (from 0)
   *  and mean update norm, once the poses are updated (getPose/getPoseMatrix return the
   *  new ones): progress reports, or recording the trajectory of a relaxation. */
  using IterationCallback = std::function<void(int iteration, double mean_update)>;
  /** Calls \a callback(iteration, mean update) after every iteration. */
  void
  setIterationCallback(IterationCallback callback)
  {
    iteration_callback_ = std::move(callback);
  }
  /** Adds link source -> target without correspondences (for pLUM mode). Throws
   *  std::out_of_range for a missing vertex, std::invalid_argument for source == target. */
  void
  addLink(const Vertex& source_vertex, const Vertex& target_vertex);

  /** A measured relative pose between two vertices besides the scan links, e.g. the
   *  front end's odometry (a pose-graph edge, g2o's EdgeSE3): getPoseMatrix(target)^-1 *
   *  getPoseMatrix(source) should be `relative`; `information` is the inverse covariance
   *  of the error (translation, rotation vector) of a body-frame perturbation
   *  source Exp(e) (lum::PoseConstraint). Each iteration adds it to G X = B after the
   *  links, in the order added; it also connects its vertices. cauchy_scale > 0 puts a
   *  Cauchy kernel on its squared Mahalanobis error, so that a constraint the scans
   *  contradict yields (e.g. 16.8, chi2's 99 % quantile for 6 degrees of freedom); where
   *  a link joins the same two vertices (source to target), the error is measured in that
   *  link's information of the iteration (lum::constraintBlock).
   *  Throws std::out_of_range for an unknown vertex (as addLink), std::invalid_argument
   *  for equal vertices, a non-finite pose, a non-finite or asymmetric information or a
   *  negative scale. */
  void
  addPoseConstraint(const Vertex& source_vertex,
                    const Vertex& target_vertex,
                    const Eigen::Matrix4d& relative,
                    const lum::Matrix6d& information,
                    double cauchy_scale = 0.0);
  /** Number of pose constraints added. */
  std::size_t
  getNumPoseConstraints() const
  {
    return constraints_.size();
  }
  /** Constraint k's squared Mahalanobis error at getPoseMatrix()'s poses (after compute():
   *  how far the relaxation moved its vertices from what it measured). Throws
   *  std::out_of_range for k >= getNumPoseConstraints(). */
  double
  getPoseConstraintChi2(std::size_t k) const;
  /** pLUM mode: also search the target's points in the source (default true), so both
   *  scans' overlap borders contribute pairs. */
  void
  setSymmetricCorrespondences(bool symmetric)
  {
    symmetric_ = symmetric;
  }
  /** True when pairs are searched in both directions of a link. */
  bool
  getSymmetricCorrespondences() const
  {
    return symmetric_;
  }
  /** pLUM mode: query every step-th point of a scan (default 1: all). The trees always
   *  hold all points, so matches keep the full density. */
  void
  setQueryStep(std::size_t step)
  {
    query_step_ = step > 0 ? step : 1;
  }
  /** Every k-th point is a query (setQueryStep). */
  std::size_t
  getQueryStep() const
  {
    return query_step_;
  }
  /** Links with fewer valid pairs are dropped for the iteration (default 10, >= 3). */
  void
  setMinCorrespondences(std::size_t n)
  {
    min_correspondences_ = n;
  }
  /** Fewest valid pairs for a link to count in an iteration. */
  std::size_t
  getMinCorrespondences() const
  {
    return min_correspondences_;
  }
  /** Threads for the per-link work; 0 (default) = all cores. */
  void
  setNumberOfThreads(unsigned num_threads)
  {
    num_threads_ = num_threads;
  }
  /** Threads used (0: all cores). */
  unsigned
  getNumberOfThreads() const
  {
    return num_threads_;
  }
  /** Fraction of the source scan's finite points whose closest target point lies within
   *  max_distance, at the current poses (builds the k-d trees if needed). */
  double
  computeOverlap(const Vertex& source_vertex, const Vertex& target_vertex, double max_distance);
  /** The k-d tree pLUM searches in a vertex's cloud (built now if needed, with the
   *  normals in point-to-plane mode), for callers that query the same scans, e.g. for
   *  overlap checks, so that a scan has one tree. */
  std::shared_ptr<const KdTreeIndex>
  getSearchTree(const Vertex& vertex);
  /** Gives a vertex's k-d tree instead of building it, for a caller that built it
   *  already (the pipeline's front end, for the scan's normals): KdTreeIndex::build over
   *  the cloud's points, stride sizeof(PointT) / sizeof(float), ids left to be the cloud
   *  indices. With the default bucket size that is the tree pLUM builds itself (a tree
   *  does not depend on the threads that built it), so results are the same. It holds
   *  until the cloud changes; normals are then mapped (setPointNormals) or estimated on
   *  it. Throws std::invalid_argument for a null tree, or one whose size is not the
   *  cloud's number of finite points or whose ids lie outside it. */
  void
  setSearchTree(const Vertex& vertex, std::shared_ptr<const KdTreeIndex> tree);
  /** All pairs (i < j) whose overlap, the smaller of the two directions, is at least
   *  min_fraction, in parallel over pairs. Returns them; does not add links. */
  std::vector<std::pair<Vertex, Vertex>>
  findOverlappingPairs(double max_distance, double min_fraction);

  /** Iterations run by the last compute(), and its last mean update norm. */
  int
  getNumIterationsDone() const
  {
    return iterations_done_;
  }
  /** Mean pose update of the last iteration. */
  double
  getLastMeanUpdate() const
  {
    return last_mean_update_;
  }
  /** Links dropped in the last iteration. */
  std::size_t
  getNumDroppedLinks() const
  {
    return dropped_links_;
  }

private:
  /** One thread's search state (paper Sec. IV-B / V): the padded slot and the query it
   *  points to, on their own cache lines. */
  struct alignas(kCacheLineSize) ThreadState {
    NearestSlot slot;
    float query[3];
  };

  struct LinkRef {
    Vertex source;
    Vertex target;
    Edge edge;
    std::size_t duplicate; ///< earlier links with the same (source, target)
  };
  /** A link's hints for one search direction: (source, target, duplicate, pass). */
  using HintKey = std::tuple<Vertex, Vertex, std::size_t, int>;

  // mpi::DistributedLUM runs compute()'s steps on different ranks (docs/design.md, MPI).
  template <typename>
  friend class mpi::DistributedLUM;

  /** The state of one compute(), split into its steps so that another driver can run the
   *  links' part (steps 1-2) and the solve (steps 3-5) in different processes. */
  struct Run {
    std::vector<LinkRef> links;
    std::vector<lum::LinkBlock, Eigen::aligned_allocator<lum::LinkBlock>> blocks;
    std::vector<const char*> reasons;
    std::vector<std::size_t> pair_counts;
    std::vector<pcl::CorrespondencesPtr> link_corrs;
    std::vector<ThreadState> states; // paper Sec. IV-B/V: padded, one per thread
    std::vector<lum::Vector6d, Eigen::aligned_allocator<lum::Vector6d>> delta;
    std::vector<std::size_t> mine; ///< the links this process measures, ascending
    bool plum = false;
    unsigned threads = 1;
  };
  /** Picks the links one process measures (indices into the link order, ascending). */
  using LinkSelection = std::function<std::vector<std::size_t>(const std::vector<LinkRef>&)>;
  /** Syncs the poses, checks the graph and builds the trees. This process measures the
   *  links `select` picks (empty: all): only their vertices need clouds and trees. */
  void
  beginCompute(Run& run, const LinkSelection& select = {});
  /** Steps 1-2 of iteration `it` for the links run.mine: fills their blocks. */
  void
  measureLinks(Run& run, int it);
  /** Steps 3-5 from all blocks; false when compute() is to stop. */
  bool
  solveIteration(Run& run, int it);
  void
  endCompute(Run& run);

  void
  syncPoses();
  void
  writeBackPoses();
  std::vector<LinkRef>
  collectLinks() const;
  /** Clouds are checked for the vertices of the links `mine` only (all links: every
   *  vertex). */
  void
  validate(const std::vector<LinkRef>& links, const std::vector<std::size_t>& mine) const;
  /** Trees of the vertices with needed[v] (null: all that have a cloud). */
  void
  buildTrees(const std::vector<char>* needed = nullptr);
  /** Sizes the per-vertex trees, their sources and normals to the vertices. */
  void
  resizeVertexState();
  /** One pairing step of a link within max_distance, the source scan moved by `motion`
   *  (world frame) on top of its pose; pairs go to acc (and out, if given). */
  void
  computeLinkPairs(const LinkRef& link,
                   double max_distance,
                   const Eigen::Matrix4d& motion,
                   ThreadState& state,
                   lum::LinkAccumulator& acc,
                   pcl::Correspondences* out);
  /** Steps 1-2 of the paper for one link in pLUM mode, with getLinkIterations() pairing
   *  steps; fills the block, false (with a reason) if the link is to be dropped. */
  bool
  measureLink(const LinkRef& link,
              double max_distance,
              ThreadState& state,
              lum::LinkBlock& block,
              pcl::Correspondences* out,
              std::size_t& num_pairs,
              const char** reason);
  void
  computeLinkFixed(const LinkRef& link, lum::LinkAccumulator& acc) const;
  void
  checkVertex(const Vertex& v, const char* where) const;
  /** computeOverlap() without syncing poses or building trees (safe in parallel). */
  double
  overlap(const Vertex& source_vertex, const Vertex& target_vertex, double max_distance) const;

  SLAMGraphPtr slam_graph_;
  int max_iterations_ = 5;
  float convergence_threshold_ = 0.0f;
  double correspondence_distance_ = 0.0;
  double final_correspondence_distance_ = 0.0;
  double correspondence_distance_factor_ = 1.0;
  bool point_to_plane_ = false;
  bool planar_ = false;
  double point_to_point_weight_ = 0.01;
  std::size_t normal_neighbours_ = 10;
  int link_iterations_ = 1;
  IterationCallback iteration_callback_;
  std::size_t min_correspondences_ = 10;
  bool symmetric_ = true;
  std::size_t query_step_ = 1;
  unsigned num_threads_ = 0;

  // Master copy of the poses (double) and the 6-vectors last written to the graph: a
  // vertex whose graph pose_ differs from its mirror was changed through the graph and
  // is re-read from it.
  std::vector<Eigen::Matrix4d> poses_;
  std::vector<Eigen::Vector6f, Eigen::aligned_allocator<Eigen::Vector6f>> mirrors_;

  // Per-vertex k-d trees in the scan's own frame, rebuilt when the cloud changes.
  std::vector<std::shared_ptr<const KdTreeIndex>> trees_;
  std::vector<std::pair<const PointCloud*, std::size_t>> tree_source_;
  /// addPoseConstraint's measurements, added to G X = B after the links in this order
  std::vector<lum::PoseConstraint, Eigen::aligned_allocator<lum::PoseConstraint>> constraints_;
  // Point-to-plane mode: per-vertex normals by tree position, computed with neighbours k
  // (0 = not computed), in the scan's own frame.
  std::vector<std::vector<Eigen::Vector3f>> normals_;
  std::vector<std::size_t> normals_k_; ///< or kGivenNormals: from given_normals_
  /// setPointNormals' normals by point index, until buildTrees maps them to tree positions
  std::vector<std::vector<Eigen::Vector3f>> given_normals_;
  static constexpr std::size_t kGivenNormals = static_cast<std::size_t>(-1);
  // Warm-start hints (last iteration's matches), one vector per link and search direction:
  // a reversed (b -> a) or repeated link has its own, so no two threads share one.
  std::map<HintKey, std::vector<std::uint32_t>> hints_;

  /** The solver with its factorisation; a copy of ParallelLUM starts with a fresh one
   *  (PCL's LUM is copyable, so ours is too; the graph is shared, as PCL's copy shares it). */
  struct SolverSlot {
    std::unique_ptr<lum::PoseGraphSolver> ptr{new lum::PoseGraphSolver};
    SolverSlot() = default;
    SolverSlot(const SolverSlot&)
        : ptr(new lum::PoseGraphSolver)
    {}
    SolverSlot&
    operator=(const SolverSlot&)
    {
      ptr.reset(new lum::PoseGraphSolver);
      return *this;
    }
    SolverSlot(SolverSlot&&) noexcept = default;
    SolverSlot&
    operator=(SolverSlot&&) noexcept = default;
    lum::PoseGraphSolver*
    operator->() const
    {
      return ptr.get();
    }
  };
  SolverSlot solver_;
  int iterations_done_ = 0;
  double last_mean_update_ = 0.0;
  std::size_t dropped_links_ = 0;
};

} // namespace pcl_parallel

#ifdef PCL_NO_PRECOMPILE
#include <pcl_parallel/registration/impl/lum.hpp>
#endif

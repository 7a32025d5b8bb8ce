#pragma once
// Point-to-point ICP (Besl and McKay 1992) on any SearchIndex: each iteration pairs every query point
// with its nearest model point within the current maximal distance (ranged search, k = 1, native or
// emulated as the adapter declares), then solves for the rigid transform in closed form (SVD of the
// cross-covariance, Arun et al. 1987 / Umeyama 1991).
#include "nnb/cloud.hpp"
#include "nnb/search_index.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace nnb::icp {

/// Maximal correspondence distance per iteration: max(start_m * factor^i, floor_m); factor 1 = fixed.
struct DistanceSchedule {
  double start_m = 0.5;
  double factor = 1.0;   ///< in (0, 1]
  double floor_m = 0.0;  ///< the schedule never goes below this (ignored when factor == 1)

  /// The maximal distance in metres for iteration i (0-based).
  double at(int iteration) const;
  /// True once the schedule has reached its final value at iteration i.
  bool settled(int iteration) const;
};

inline constexpr int kMaxIterations = 100000;

struct Options {
  Eigen::Matrix4d initial_pose = Eigen::Matrix4d::Identity();  ///< maps query points into the model frame
  DistanceSchedule max_dist;
  int max_iterations = 50;
  /// Converged when one update moves the pose by less than both thresholds (and the schedule settled).
  double min_translation_step_m = 1e-6;
  double min_rotation_step_rad = 1e-6;
  std::size_t min_correspondences = 3;  ///< fewer pairs than this ends the run as a failure
  /// Search with the previous iteration's neighbours as hints (adapters that use hints; same answers).
  bool use_hints = true;
  /// Track each query's neighbour between iterations (NeighbourTrack): a query that has moved less than its
  /// margin keeps it without a search; the others are searched for their two nearest (same answers).
  bool track_neighbours = false;
};

struct Iteration {
  double max_dist_m = 0.0;            ///< the limit the search used
  std::size_t correspondences = 0;    ///< query points that found a model point within the limit
  double rms_m = 0.0;                 ///< RMS pair distance at the pose searched from
  double rms_after_m = 0.0;           ///< RMS of the same pairs after this iteration's update
  double translation_step_m = 0.0;    ///< how far the update moved the pose
  double rotation_step_rad = 0.0;
};

struct Result {
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();  ///< final estimate, query -> model frame; always finite
  int iterations = 0;                  ///< updates computed
  bool converged = false;              ///< the step thresholds were met before the iteration limit
  std::string failure;                 ///< empty unless the run stopped early (too few pairs, degenerate)
  std::vector<Iteration> per_iteration;
  double build_seconds = 0.0;          ///< index construction
  double nns_seconds = 0.0;            ///< nearest-neighbour searches
  double estimate_seconds = 0.0;       ///< moving the query points and solving for the transform
  /// RMS pair distance in metres after the last update (0 when no iteration ran).
  double final_rms_m() const { return per_iteration.empty() ? 0.0 : per_iteration.back().rms_after_m; }
  /// Correspondences of the last iteration.
  std::size_t final_correspondences() const {
    return per_iteration.empty() ? 0 : per_iteration.back().correspondences;
  }
};

/// Greenspan and Godin's ICP search, centred on the query: when a query's two nearest model points lay at
/// distances a < b, every point but the nearest lay at least b away. After the query moves by delta, its
/// old nearest is still its nearest whenever it lies nearer than b - delta, and the search can be skipped.
/// Where none lay within the limit L, none lies within L' while delta < L - L'. The bounds keep a margin of
/// 2^-20 of b, far above the rounding of the computed distances, so the answers are the search's.
class NeighbourTrack {
 public:
  /// Fills pairs with each query's nearest model point within max_dist_m, as
  /// index.ranged(queries, 1, max_dist_m, pairs) would: proven from the last call's state where the query
  /// moved little enough, else searched: for its two nearest, to set its state anew, except right after
  /// such a fresh state failed (then for its nearest only, a cheaper search; the next call searches for
  /// two again). The same queries, in the same order, at every call.
  void ranged(const SearchIndex& index, const Cloud& model, const Cloud& queries, double max_dist_m, Neighbours& pairs);
  /// Queries answered without a search in the last call.
  std::size_t proven() const { return proven_; }
  /// Queries searched for their nearest only in the last call (their margin, fresh from the call before, failed).
  std::size_t searched_for_one() const { return single_.size(); }

 private:
  /// How far beyond the limit (in limits) the nearest of a query with none within it is looked for.
  static constexpr double kFarLimits = 2.0;

  /// Proves what it can from the state; sets searched_ (to search for two) and single_ (for one: they were
  /// searched for two in the last call and their margin did not hold, so they are unlikely to hold next).
  void prove_or_pick_search(const Cloud& model, const Cloud& queries, double max_dist_m);
  /// Writes every query's row from its proof or its search, and the searched queries' new state.
  void fill_pairs(const Cloud& queries, double max_dist_m, Neighbours& pairs);
  /// Sets far_clear_m_ for the searched queries that found nothing within the limit: their nearest's distance,
  /// up to kFarLimits times the limit.
  void far_clear_of_none(const SearchIndex& index, double max_dist_m);
  /// Sets tied_nearest_ for the searched queries whose two nearest tie: the plain search's choice.
  void nearest_of_tied(const SearchIndex& index, double max_dist_m);
  /// Searches the searched queries `which` (positions in searched_) again for one neighbour, into again_.
  void search_again(const SearchIndex& index, const std::vector<PointIndex>& which, double max_dist_m);
  /// The ranged k-NN of the columns `which` of queries (gathered into `gathered`), into out.
  static void search_columns(const SearchIndex& index, const Cloud& queries, const std::vector<PointIndex>& which,
                             int k, double max_dist_m, Cloud& gathered, Neighbours& out);

  // Each query's state, kept between calls.
  Cloud at_;                        ///< each query where its state was set
  std::vector<PointIndex> nearest_; ///< its nearest model point there, or kNoHint
  std::vector<double> clear_m_;     ///< every other model point lay farther than this from at_
  std::vector<std::uint8_t> searched_two_;  ///< 1: its state was set by a search for two in the last call
  // One call's work, its memory kept between calls.
  std::vector<double> proven_sq_;   ///< per query: its proven squared distance, or -1 when searched
  std::vector<PointIndex> searched_;
  Cloud searched_queries_;
  Neighbours two_;                  ///< the searched queries' two nearest
  std::vector<PointIndex> single_;
  Cloud single_queries_;
  Neighbours one_;                  ///< the single_ queries' nearest
  std::vector<double> far_clear_m_;
  std::vector<PointIndex> tied_nearest_;
  std::vector<PointIndex> again_which_;
  Cloud again_queries_;
  Neighbours again_;
  std::size_t proven_ = 0;
};

/// Throws InputError unless options are usable (positive distances, factor in (0,1], a rigid initial pose).
void validate(const Options& options);

/// Throws InputError (naming `what`) unless m is finite, has last row 0 0 0 1 and a rotation block with
/// |R^T R - I| <= 1e-4 and det(R) > 0; returns m with its rotation projected exactly onto SO(3).
Eigen::Matrix4d checked_rigid(const Eigen::Matrix4d& m, const std::string& what);

/// What the closed-form fit needs of paired points, gathered in one pass: sums of both sides and of their
/// products, taken relative to the first pair (so that a cloud far from the origin loses no digits).
struct PairMoments {
  Eigen::Index n = 0;
  Eigen::Vector3d source_shift = Eigen::Vector3d::Zero(), target_shift = Eigen::Vector3d::Zero();  ///< metres
  Eigen::Vector3d source_sum = Eigen::Vector3d::Zero(), target_sum = Eigen::Vector3d::Zero();      ///< metres
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();  ///< sum of (source - shift)(target - shift)^T, m^2
  double source_sq_m2 = 0.0, target_sq_m2 = 0.0;    ///< sums of |source - shift|^2 and |target - shift|^2
  void add(const Eigen::Vector3d& source, const Eigen::Vector3d& target);
};

/// The rigid transform minimising sum |T * source_i - target_i|^2 over the pairs (least squares, no
/// scale); returns false (and leaves out untouched) when fewer than 3 pairs or the pairs are degenerate.
bool rigid_transform_from(const PairMoments& moments, Eigen::Matrix4d& out);
/// The same over paired columns of source and target.
bool estimate_rigid_transform(const Cloud& source, const Cloud& target, Eigen::Matrix4d& out);

/// The moments of the pairs a ranged 1-NN search found (query point q with its first neighbour); adds
/// their squared distances to sum_sq_m2.
PairMoments pair_moments(const Neighbours& pairs, const Cloud& query, const Cloud& model, double& sum_sq_m2);
/// sum |pose * source_i - target_i|^2 (m^2) over the pairs, from their moments alone: the fit's residual
/// without a second pass over the paired points. Its rounding is that of the moments, about 1e-15 of
/// sum |source - shift|^2 (a residual of micrometres on a cloud 50 m wide); never below 0.
double sum_sq_after_m2(const PairMoments& moments, const Eigen::Matrix4d& pose);
/// Writes pose * query into moved (resized).
void move_queries(const Cloud& query, const Eigen::Matrix4d& pose, Cloud& moved);

/// Rotation angle of a rigid transform's rotation block, in radians.
double rotation_angle_rad(const Eigen::Matrix4d& transform);

/// Registers query onto an index already built over model (build_seconds stays 0).
Result register_prebuilt(const SearchIndex& index, const Cloud& model, const Cloud& query, const Options& options);

}  // namespace nnb::icp

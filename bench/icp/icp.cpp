#include "icp.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

namespace nnb::icp {
namespace {

using Clock = std::chrono::steady_clock;

// The model points of the pairs, read in the queries' order, lie scattered over the model: a cache miss
// each that the loop's arithmetic cannot hide. Asking early for the one kAheadPairs pairs ahead keeps
// several misses in flight.
class ModelPrefetch {
 public:
  ModelPrefetch(const Neighbours& pairs, const double* model_xyz)
      : indices_(pairs.indices.data()), last_(pairs.indices.empty() ? 0 : pairs.indices.size() - 1), xyz_(model_xyz) {}
  void ahead_of(std::size_t at) const {
    __builtin_prefetch(xyz_ + 3 * static_cast<std::size_t>(indices_[std::min(at + kAheadPairs, last_)]));
  }

 private:
  static constexpr std::size_t kAheadPairs = 48;
  const PointIndex* indices_;
  std::size_t last_;
  const double* xyz_;
};

// Two doubles in one register, for sums kept side by side.
using V2 = double __attribute__((vector_size(16)));

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string str(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// Nearest rotation to m in the Frobenius norm (polar decomposition through the SVD).
Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

}  // namespace

double DistanceSchedule::at(int iteration) const {
  if (factor >= 1.0) return start_m;
  return std::max(start_m * std::pow(factor, iteration), floor_m);
}

bool DistanceSchedule::settled(int iteration) const {
  return factor >= 1.0 || start_m * std::pow(factor, iteration) <= floor_m;
}

Eigen::Matrix4d checked_rigid(const Eigen::Matrix4d& m, const std::string& what) {
  if (!m.allFinite()) throw InputError(what + " has a non-finite entry");
  if (m.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) throw InputError(what + ": the last row must be 0 0 0 1");
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double off = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (off > 1e-4 || r.determinant() <= 0.0) {
    throw InputError(what + " is not rigid: |R^T R - I| = " + str(off) + ", det(R) = " + str(r.determinant()) +
                     " (need a rotation and a translation, no scale, shear or mirror)");
  }
  Eigen::Matrix4d out = m;
  out.topLeftCorner<3, 3>() = nearest_rotation(r);
  return out;
}

void validate(const Options& options) {
  const auto& s = options.max_dist;
  if (!std::isfinite(s.start_m) || s.start_m <= 0.0) {
    throw InputError("ICP: the maximal distance must be a finite distance > 0 m (got " + str(s.start_m) + ")");
  }
  if (!(s.factor > 0.0 && s.factor <= 1.0)) {
    throw InputError("ICP: the maximal distance factor must lie in (0, 1] (got " + str(s.factor) + ")");
  }
  if (!std::isfinite(s.floor_m) || s.floor_m < 0.0 || s.floor_m > s.start_m) {
    throw InputError("ICP: the final maximal distance must lie in [0, start] m (got " + str(s.floor_m) + ")");
  }
  if (s.factor < 1.0 && s.floor_m <= 0.0) {
    throw InputError("ICP: a shrinking maximal distance needs a final value > 0 m");
  }
  // Each iteration is kept in the result and its file: a limit far beyond any ICP's would only fill memory.
  if (options.max_iterations < 1 || options.max_iterations > kMaxIterations) {
    throw InputError("ICP: the iteration limit must lie in [1, " + std::to_string(kMaxIterations) + "] (got " +
                     std::to_string(options.max_iterations) + ")");
  }
  if (!(options.min_translation_step_m >= 0.0) || !(options.min_rotation_step_rad >= 0.0)) {
    throw InputError("ICP: convergence thresholds must be >= 0");
  }
  if (options.min_correspondences < 3) throw InputError("ICP: at least 3 correspondences are needed per iteration");
  checked_rigid(options.initial_pose, "ICP: the initial pose");
}

void PairMoments::add(const Eigen::Vector3d& source, const Eigen::Vector3d& target) {
  if (n == 0) {
    source_shift = source;
    target_shift = target;
  }
  const Eigen::Vector3d s = source - source_shift;
  const Eigen::Vector3d t = target - target_shift;
  ++n;
  source_sum += s;
  target_sum += t;
  cross += s * t.transpose();
  source_sq_m2 += s.squaredNorm();
  target_sq_m2 += t.squaredNorm();
}

bool rigid_transform_from(const PairMoments& m, Eigen::Matrix4d& out) {
  if (m.n < 3) return false;
  const double count = static_cast<double>(m.n);
  const Eigen::Vector3d source_mean = m.source_sum / count;
  const Eigen::Vector3d target_mean = m.target_sum / count;
  const Eigen::Matrix3d cross = m.cross - count * source_mean * target_mean.transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  // Collinear (or coincident) pairs leave a rotation about their line free: no unique answer.
  if (!sv.allFinite() || !(sv(0) > 0.0) || sv(1) <= 1e-12 * sv(0)) return false;
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  // A reflection would fit better only for planar or bad pairs; force a proper rotation (Umeyama).
  d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d rotation = svd.matrixV() * d * svd.matrixU().transpose();
  Eigen::Matrix4d result = Eigen::Matrix4d::Identity();
  result.topLeftCorner<3, 3>() = rotation;
  result.topRightCorner<3, 1>() =
      (m.target_shift + target_mean) - rotation * (m.source_shift + source_mean);
  if (!result.allFinite()) return false;
  out = result;
  return true;
}

bool estimate_rigid_transform(const Cloud& source, const Cloud& target, Eigen::Matrix4d& out) {
  if (target.cols() != source.cols()) return false;
  PairMoments m;
  for (Eigen::Index i = 0; i < source.cols(); ++i) m.add(source.col(i), target.col(i));
  return rigid_transform_from(m, out);
}

PairMoments pair_moments(const Neighbours& pairs, const Cloud& query, const Cloud& model, double& sum_sq_m2) {
  PairMoments m;
  std::size_t q = 0;
  while (q < pairs.n_queries() && pairs.count(q) == 0) ++q;
  if (q == pairs.n_queries()) return m;
  m.source_shift = query.col(static_cast<Eigen::Index>(q));
  m.target_shift = model.col(static_cast<Eigen::Index>(pairs.indices[pairs.offsets[q]]));
  // Nineteen sums in ten two-lane vectors (GCC's generic vectors: SSE2 here, NEON or scalars elsewhere), so
  // that none leaves a register. Each lane is one plain sum, added pair after pair as a scalar loop would.
  // Row i of the cross products: (s_i t_0, s_i t_1) and (s_i t_2, s_i * 1), the latter lane the sum of s_i.
  V2 row01[3] = {}, row2_s[3] = {};
  V2 t01_sum = {}, t2_sq_sum = {};  // (t_0, t_1); (t_2, the search's squared distance)
  V2 sq_sum = {};                   // (|s|^2, |t|^2)
  const V2 s_shift01 = {m.source_shift[0], m.source_shift[1]}, t_shift01 = {m.target_shift[0], m.target_shift[1]};
  const double s_shift2 = m.source_shift[2], t_shift2 = m.target_shift[2];
  Eigen::Index n = 0;
  const double* const qp = query.data();
  const double* const mp = model.data();
  const std::size_t* const offsets = pairs.offsets.data();
  const PointIndex* const indices = pairs.indices.data();
  const double* const sq_dists = pairs.sq_dists.data();
  const ModelPrefetch prefetch(pairs, mp);
  for (; q < pairs.n_queries(); ++q) {
    const std::size_t at = offsets[q];
    if (offsets[q + 1] == at) continue;
    prefetch.ahead_of(at);
    const double* const a = qp + 3 * q;
    const double* const b = mp + 3 * static_cast<std::size_t>(indices[at]);
    const V2 s01 = V2{a[0], a[1]} - s_shift01, t01 = V2{b[0], b[1]} - t_shift01;
    const double s2 = a[2] - s_shift2, t2 = b[2] - t_shift2;
    const V2 t2_one = {t2, 1.0};
    const double s[3] = {s01[0], s01[1], s2};
    for (int i = 0; i < 3; ++i) {
      const V2 si = {s[i], s[i]};
      row01[i] += si * t01;
      row2_s[i] += si * t2_one;
    }
    t01_sum += t01;
    t2_sq_sum += V2{t2, sq_dists[at]};
    const V2 x0 = {s01[0], t01[0]}, x1 = {s01[1], t01[1]}, x2 = {s2, t2};
    sq_sum += (x0 * x0 + x1 * x1) + x2 * x2;
    ++n;
  }
  m.n = n;
  m.source_sq_m2 = sq_sum[0];
  m.target_sq_m2 = sq_sum[1];
  m.target_sum = Eigen::Vector3d(t01_sum[0], t01_sum[1], t2_sq_sum[0]);
  for (int i = 0; i < 3; ++i) {
    m.cross.row(i) << row01[i][0], row01[i][1], row2_s[i][0];
    m.source_sum[i] = row2_s[i][1];
  }
  sum_sq_m2 += t2_sq_sum[1];
  return m;
}

double sum_sq_after_m2(const PairMoments& m, const Eigen::Matrix4d& pose) {
  // |R s + c - t|^2 summed, with s and t taken from their shifts and c = R source_shift + p - target_shift.
  const Eigen::Matrix3d r = pose.topLeftCorner<3, 3>();
  const Eigen::Vector3d c = r * m.source_shift + pose.topRightCorner<3, 1>() - m.target_shift;
  const double n = static_cast<double>(m.n);
  const double sum = m.source_sq_m2 + m.target_sq_m2 + n * c.squaredNorm() +
                     2.0 * c.dot(r * m.source_sum - m.target_sum) - 2.0 * (r * m.cross).trace();
  return std::max(sum, 0.0);
}

void move_queries(const Cloud& query, const Eigen::Matrix4d& pose, Cloud& moved) {
  double r[3][4];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) r[i][j] = pose(i, j);
  }
  moved.resize(3, query.cols());
  const double* const in = query.data();
  double* const out = moved.data();
  const std::size_t n = static_cast<std::size_t>(query.cols());
  for (std::size_t q = 0; q < n; ++q) {
    const double* const p = in + 3 * q;
    for (int i = 0; i < 3; ++i) out[3 * q + i] = r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2] + r[i][3];
  }
}

double rotation_angle_rad(const Eigen::Matrix4d& transform) {
  // atan2 of sine and cosine: acos of the trace alone loses half the digits near 0 (2e-8 rad floor).
  const Eigen::Matrix3d r = transform.topLeftCorner<3, 3>();
  const Eigen::Vector3d axis_sin(r(2, 1) - r(1, 2), r(0, 2) - r(2, 0), r(1, 0) - r(0, 1));
  return std::atan2(0.5 * axis_sin.norm(), 0.5 * (r.trace() - 1.0));
}

void NeighbourTrack::ranged(const SearchIndex& index, const Cloud& model, const Cloud& queries, double max_dist_m,
                            Neighbours& pairs) {
  const auto n = static_cast<std::size_t>(queries.cols());
  if (nearest_.size() != n) {
    at_ = queries;
    nearest_.assign(n, kNoHint);
    clear_m_.assign(n, 0.0);  // nothing proven: every query is searched
    searched_two_.assign(n, 0);
  }
  prove_or_pick_search(model, queries, max_dist_m);
  search_columns(index, queries, searched_, 2, max_dist_m, searched_queries_, two_);
  search_columns(index, queries, single_, 1, max_dist_m, single_queries_, one_);
  far_clear_of_none(index, max_dist_m);
  nearest_of_tied(index, max_dist_m);
  fill_pairs(queries, max_dist_m, pairs);
}

void NeighbourTrack::prove_or_pick_search(const Cloud& model, const Cloud& queries, double max_dist_m) {
  const auto n = static_cast<std::size_t>(queries.cols());
  const double keep = 1.0 - std::ldexp(1.0, -20);
  searched_.clear();
  single_.clear();
  // A proven query's squared distance to its old nearest (infinite: proven to have none); -1: searched.
  proven_sq_.assign(n, -1.0);
  for (std::size_t q = 0; q < n; ++q) {
    const double* p = queries.data() + 3 * q;
    const double delta_m = std::sqrt(sq_dist_m2(p, at_.data() + 3 * q));
    const double clear_m = clear_m_[q] * keep;
    if (nearest_[q] == kNoHint) {
      if (clear_m - delta_m > max_dist_m) proven_sq_[q] = std::numeric_limits<double>::infinity();
    } else {
      const double sq = sq_dist_m2(p, model.data() + 3 * static_cast<std::size_t>(nearest_[q]));
      if (std::sqrt(sq) + delta_m < clear_m) proven_sq_[q] = sq;
    }
    // A query whose fresh margin failed at once is likely to fail again: it is searched for one (cheaper)
    // this time, and for two the next.
    if (proven_sq_[q] >= 0.0) searched_two_[q] = 0;
    else if (searched_two_[q] != 0) single_.push_back(static_cast<PointIndex>(q));
    else searched_.push_back(static_cast<PointIndex>(q));
  }
  proven_ = n - searched_.size() - single_.size();
}

void NeighbourTrack::fill_pairs(const Cloud& queries, double max_dist_m, Neighbours& pairs) {
  const auto n = static_cast<std::size_t>(queries.cols());
  const double limit_sq_m2 = max_dist_m * max_dist_m;
  pairs.reset(n, n);
  std::size_t s = 0, u = 0;
  for (std::size_t q = 0; q < n; ++q) {
    if (s < searched_.size() && searched_[s] == q) {
      const std::size_t at = two_.offsets[s];
      const std::size_t found = two_.count(s);
      PointIndex nearest = kNoHint;
      if (found > 0) {
        nearest = tied_nearest_[s] != kNoHint ? tied_nearest_[s] : two_.indices[at];
        pairs.push(nearest, two_.sq_dists[at]);
      }
      at_.col(static_cast<Eigen::Index>(q)) = queries.col(static_cast<Eigen::Index>(q));
      nearest_[q] = nearest;
      clear_m_[q] = found > 1 ? std::sqrt(two_.sq_dists[at + 1]) : found == 1 ? max_dist_m : far_clear_m_[s];
      searched_two_[q] = 1;
      ++s;
    } else if (u < single_.size() && single_[u] == q) {
      // Its own nearest only: it proves nothing next time, when it is searched for two again.
      const bool found = one_.count(u) > 0;
      if (found) pairs.push(one_.indices[one_.offsets[u]], one_.sq_dists[one_.offsets[u]]);
      nearest_[q] = found ? one_.indices[one_.offsets[u]] : kNoHint;
      clear_m_[q] = 0.0;
      searched_two_[q] = 0;
      ++u;
    } else if (proven_sq_[q] <= limit_sq_m2) {
      pairs.push(nearest_[q], proven_sq_[q]);
    }
    pairs.end_query();
  }
}

void NeighbourTrack::search_again(const SearchIndex& index, const std::vector<PointIndex>& which, double max_dist_m) {
  search_columns(index, searched_queries_, which, 1, max_dist_m, again_queries_, again_);
}

void NeighbourTrack::search_columns(const SearchIndex& index, const Cloud& queries, const std::vector<PointIndex>& which,
                                    int k, double max_dist_m, Cloud& gathered, Neighbours& out) {
  if (which.empty()) {
    out.reset();
    return;
  }
  gather_columns(queries, which, gathered);
  index.ranged(gathered, k, max_dist_m, out);
}

void NeighbourTrack::far_clear_of_none(const SearchIndex& index, double max_dist_m) {
  // A query with nothing within the limit searches its whole ball every time; its nearest point's distance
  // (or kFarLimits limits, when nothing lies that near: looking further costs more than it proves) lets the
  // next calls prove that nothing came within the limit.
  again_which_.clear();
  for (std::size_t s = 0; s < searched_.size(); ++s) {
    if (two_.count(s) == 0) again_which_.push_back(static_cast<PointIndex>(s));
  }
  far_clear_m_.assign(searched_.size(), 0.0);
  if (again_which_.empty()) return;
  const double far_m = kFarLimits * max_dist_m;
  search_again(index, again_which_, far_m);
  for (std::size_t u = 0; u < again_which_.size(); ++u) {
    far_clear_m_[again_which_[u]] = again_.count(u) > 0 ? std::sqrt(again_.sq_dists[again_.offsets[u]]) : far_m;
  }
}

void NeighbourTrack::nearest_of_tied(const SearchIndex& index, double max_dist_m) {
  // Two nearest at the same distance: which one the plain search returns is the adapter's choice, so it
  // is asked for (a tie leaves the query's margin at zero: it is searched again next time).
  again_which_.clear();
  for (std::size_t s = 0; s < searched_.size(); ++s) {
    if (two_.count(s) == 2 && two_.sq_dists[two_.offsets[s]] == two_.sq_dists[two_.offsets[s] + 1]) {
      again_which_.push_back(static_cast<PointIndex>(s));
    }
  }
  tied_nearest_.assign(searched_.size(), kNoHint);
  if (again_which_.empty()) return;
  search_again(index, again_which_, max_dist_m);
  for (std::size_t u = 0; u < again_which_.size(); ++u) {
    if (again_.count(u) > 0) tied_nearest_[again_which_[u]] = again_.indices[again_.offsets[u]];
  }
}

namespace {

// Each query's neighbour in the last search (kNoHint where it had none): the next search's hints.
void previous_neighbours(const Neighbours& pairs, std::vector<PointIndex>& hints) {
  hints.resize(pairs.n_queries());
  for (std::size_t q = 0; q < pairs.n_queries(); ++q) {
    hints[q] = pairs.count(q) > 0 ? pairs.indices[pairs.offsets[q]] : kNoHint;
  }
}

void check_inputs(const SearchIndex& index, const Cloud& model, const Cloud& query, const Options& options) {
  validate(options);
  if (index.model_size() != static_cast<std::size_t>(model.cols())) {
    throw InputError("ICP: the index was not built over this model cloud");
  }
  if (query.cols() < 3) throw InputError("ICP: the query cloud needs at least 3 points");
  if (const auto bad = first_non_finite(query); bad >= 0) {
    throw InputError("ICP: query point " + std::to_string(bad) + " has a non-finite coordinate");
  }
}

// One iteration after the search: the rigid transform that best maps the pairs, the step it makes, and
// the query points moved for the next search (moved). Sets result.failure (and returns false) when
// there are too few pairs or they are degenerate.
bool estimate_step(const Neighbours& pairs, const Cloud& query, const Cloud& model, const Options& options, int i,
                   Cloud& moved, Iteration& it, Result& result) {
  it.correspondences = pairs.queries_with_neighbours();
  if (it.correspondences < options.min_correspondences) {
    result.failure = "too few correspondences (" + std::to_string(it.correspondences) + " within " +
                     str(it.max_dist_m) + " m) at iteration " + std::to_string(i + 1);
    return false;
  }
  double sum_sq_m2 = 0.0;
  const PairMoments m = pair_moments(pairs, query, model, sum_sq_m2);
  const double n = static_cast<double>(m.n);
  it.rms_m = std::sqrt(sum_sq_m2 / n);
  Eigen::Matrix4d next;
  if (!rigid_transform_from(m, next)) {
    result.failure = "degenerate correspondences (collinear or coincident) at iteration " + std::to_string(i + 1);
    return false;
  }
  const Eigen::Matrix4d step = next * result.pose.inverse();
  it.translation_step_m = step.topRightCorner<3, 1>().norm();
  it.rotation_step_rad = rotation_angle_rad(step);
  it.rms_after_m = std::sqrt(sum_sq_after_m2(m, next) / n);
  move_queries(query, next, moved);
  result.pose = next;
  return true;
}

}  // namespace

Result register_prebuilt(const SearchIndex& index, const Cloud& model, const Cloud& query, const Options& options) {
  check_inputs(index, model, query, options);
  Result result;
  result.pose = checked_rigid(options.initial_pose, "ICP: the initial pose");
  Neighbours pairs;
  Cloud moved;
  const bool hinted = options.use_hints && index.info().uses_hints;
  std::vector<PointIndex> hints;
  NeighbourTrack track;
  auto t0 = Clock::now();
  move_queries(query, result.pose, moved);
  result.estimate_seconds += seconds_since(t0);
  for (int i = 0; i < options.max_iterations; ++i) {
    Iteration it;
    it.max_dist_m = options.max_dist.at(i);

    t0 = Clock::now();
    if (options.track_neighbours) {
      track.ranged(index, model, moved, it.max_dist_m, pairs);
    } else if (hinted && i > 0) {
      previous_neighbours(pairs, hints);
      index.ranged_hinted(moved, it.max_dist_m, hints, pairs);
    } else {
      index.ranged(moved, 1, it.max_dist_m, pairs);
    }
    result.nns_seconds += seconds_since(t0);

    t0 = Clock::now();
    const bool stepped = estimate_step(pairs, query, model, options, i, moved, it, result);
    result.estimate_seconds += seconds_since(t0);
    if (!stepped) break;

    result.per_iteration.push_back(it);
    result.iterations = i + 1;
    if (it.translation_step_m < options.min_translation_step_m && it.rotation_step_rad < options.min_rotation_step_rad &&
        options.max_dist.settled(i)) {
      result.converged = true;
      break;
    }
  }
  return result;
}

}  // namespace nnb::icp

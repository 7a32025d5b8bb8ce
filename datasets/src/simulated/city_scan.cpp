// Ray casting for the simulated scans. Speed comes from the scanner's column order: all rays of one
// azimuth column lie in one vertical half-plane, so each column first intersects the 2D footprints of the
// scene (boxes, circles, ellipses) with its horizontal direction, once, and sorts the candidates by
// horizontal entry distance s_in. A ray of elevation el then only needs the candidates it can reach:
//   - a hit at range t has horizontal distance t cos(el) >= s_in, so the first candidate with
//     s_in > best_t cos(el) ends the search;
//   - rising rays stop once tan(el) exceeds the steepest (z_top - z_scanner) / s_in of the remaining
//     candidates (suffix maximum), so sky rays cost O(1).
// Vertical-walled boxes and poles are then hit exactly from s_in/s_out and their z range.
// Noise: each ray's random words come from a splitmix64 hash of (seed, ray index, surface), not from a
// sequential stream, so a ray's noise does not depend on the rays before it.
#include "nnb/datasets/city_scan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nnb::datasets {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::uint32_t kNoHit = 0xffffffffu;

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// Uniform on [0, 1) from the top 53 bits.
double unit(std::uint64_t word) { return static_cast<double>(word >> 11) * (1.0 / 9007199254740992.0); }

// Four uniforms on [-0.5, 0.5) from two words (32 bits each), summed: variance 1/3, |sum| < 2.
double irwin_hall4(std::uint64_t w1, std::uint64_t w2) {
  constexpr double k = 1.0 / 4294967296.0;
  const auto u = [&](std::uint64_t bits) { return (static_cast<double>(bits & 0xffffffffULL) + 0.5) * k - 0.5; };
  return u(w1) + u(w1 >> 32) + u(w2) + u(w2 >> 32);
}

struct Candidate {
  double s_in = 0, s_out = 0;  // horizontal entry and exit along the column, metres
  double z_bottom = 0, z_top = 0;
  std::uint32_t surface_id = 0;
  std::uint32_t index = 0;     // in its kind's vector
  SurfaceKind kind = SurfaceKind::box;
  int face = -1;               // boxes: vertical face entered at s_in (0..3 = +x, -x, +y, -y)
  double hx = 0, hy = 0;       // boxes: local horizontal direction; crowns: direction / radii
};

// Per-scan constants of a box: the scanner origin in the box's frame.
struct BoxFrame {
  double cos_yaw, sin_yaw;
  Eigen::Vector3d origin_local;
};

// Far intersection of a ray starting inside (or on) the box [lo, hi].
double exit_distance(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& lo,
                     const Eigen::Vector3d& hi) {
  double t_far = kInf;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) continue;
    t_far = std::min(t_far, std::max((lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]));
  }
  return t_far;
}

class Caster {
 public:
  Caster(const CityScene& scene, const ScannerPose& pose) : scene_(scene), origin_(pose.position) {
    for (const SceneBox& b : scene.boxes) {
      const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
      const Eigen::Vector3d r = origin_ - b.centre;
      frames_.push_back({c, s, Eigen::Vector3d(c * r.x() + s * r.y(), -s * r.x() + c * r.y(), r.z())});
    }
    ground_at_origin_ = ground_z_m(scene.ground, origin_.x(), origin_.y());
  }

  // Candidates of the column with world horizontal direction (hx, hy), sorted by s_in.
  void prepare_column(double hx, double hy, double max_s) {
    hx_ = hx;
    hy_ = hy;
    candidates_.clear();
    std::uint32_t id = 1;
    for (std::uint32_t i = 0; i < scene_.boxes.size(); ++i, ++id) add_box(i, id, max_s);
    for (std::uint32_t i = 0; i < scene_.poles.size(); ++i, ++id) add_pole(i, id, max_s);
    for (std::uint32_t i = 0; i < scene_.crowns.size(); ++i, ++id) add_crown(i, id, max_s);
    std::sort(candidates_.begin(), candidates_.end(), [](const Candidate& a, const Candidate& b) {
      return a.s_in < b.s_in || (a.s_in == b.s_in && a.surface_id < b.surface_id);
    });
    steepest_after_.assign(candidates_.size() + 1, -kInf);
    for (std::size_t k = candidates_.size(); k-- > 0;) {
      const double slope = (candidates_[k].z_top - origin_.z()) / std::max(candidates_[k].s_in, 1e-9);
      steepest_after_[k] = std::max(steepest_after_[k + 1], slope);
    }
  }

  // Nearest hit of the ray (cos_el, sin_el) in the current column, up to max_t; kNoHit if none.
  std::uint32_t cast(double cos_el, double sin_el, double tan_el, std::uint64_t ray_key, double max_t, double& t_hit) const {
    double best_t = max_t;
    std::uint32_t best_id = kNoHit;
    const double t_ground = ground_hit(cos_el, sin_el);
    if (t_ground < best_t) {
      best_t = t_ground;
      best_id = 0;
    }
    for (std::size_t k = 0; k < candidates_.size(); ++k) {
      const Candidate& c = candidates_[k];
      if (c.s_in > best_t * cos_el) break;
      if (sin_el > 0 && tan_el > steepest_after_[k]) break;
      double t = kInf;
      switch (c.kind) {
        case SurfaceKind::box: t = box_hit(c, cos_el, sin_el); break;
        case SurfaceKind::pole: t = pole_hit(c, cos_el, sin_el); break;
        case SurfaceKind::crown: t = crown_hit(c, cos_el, sin_el, ray_key); break;
        case SurfaceKind::ground: break;
      }
      if (t < best_t) {
        best_t = t;
        best_id = c.surface_id;
      }
    }
    t_hit = best_t;
    return best_id;
  }

 private:
  void add_box(std::uint32_t i, std::uint32_t id, double max_s) {
    const SceneBox& b = scene_.boxes[i];
    const BoxFrame& f = frames_[i];
    const double lx = f.cos_yaw * hx_ + f.sin_yaw * hy_, ly = -f.sin_yaw * hx_ + f.cos_yaw * hy_;
    double s_in = -kInf, s_out = kInf;
    int face = -1;
    const double dir[2] = {lx, ly};
    for (int k = 0; k < 2; ++k) {
      const double o = f.origin_local[k], h = b.half_extent_m[k];
      if (dir[k] == 0.0) {
        if (o < -h || o > h) return;
        continue;
      }
      const double t1 = (-h - o) / dir[k], t2 = (h - o) / dir[k];
      const double lo = std::min(t1, t2), hi = std::max(t1, t2);
      if (lo > s_in) {
        s_in = lo;
        face = 2 * k + (dir[k] < 0 ? 0 : 1);  // coming from + side enters the + face
      }
      s_out = std::min(s_out, hi);
    }
    if (s_in > s_out || s_out <= 0 || s_in > max_s) return;
    if (s_in < 0) {  // the scanner stands inside the footprint: only the top or bottom can be entered
      s_in = 0;
      face = -1;
    }
    Candidate c;
    c.s_in = s_in;
    c.s_out = s_out;
    c.z_bottom = b.centre.z() - b.half_extent_m.z();
    c.z_top = b.centre.z() + b.half_extent_m.z();
    c.surface_id = id;
    c.index = i;
    c.kind = SurfaceKind::box;
    c.face = face;
    c.hx = lx;
    c.hy = ly;
    candidates_.push_back(c);
  }

  void add_pole(std::uint32_t i, std::uint32_t id, double max_s) {
    const ScenePole& p = scene_.poles[i];
    const double ox = origin_.x() - p.centre_xy.x(), oy = origin_.y() - p.centre_xy.y();
    const double b = ox * hx_ + oy * hy_, cc = ox * ox + oy * oy - p.radius_m * p.radius_m;
    const double disc = b * b - cc;
    if (disc < 0 || cc <= 0) return;  // missed, or the scanner inside the pole
    const double root = std::sqrt(disc);
    const double s_in = -b - root, s_out = -b + root;
    if (s_in <= 0 || s_in > max_s) return;
    Candidate c;
    c.s_in = s_in;
    c.s_out = s_out;
    c.z_bottom = p.z_bottom_m;
    c.z_top = p.z_top_m;
    c.surface_id = id;
    c.index = i;
    c.kind = SurfaceKind::pole;
    candidates_.push_back(c);
  }

  void add_crown(std::uint32_t i, std::uint32_t id, double max_s) {
    const SceneCrown& cr = scene_.crowns[i];
    const double ex = hx_ / cr.radii_m.x(), ey = hy_ / cr.radii_m.y();
    const double qx = (origin_.x() - cr.centre.x()) / cr.radii_m.x(), qy = (origin_.y() - cr.centre.y()) / cr.radii_m.y();
    const double a = ex * ex + ey * ey, b = qx * ex + qy * ey, cc = qx * qx + qy * qy - 1.0;
    const double disc = b * b - a * cc;
    if (disc < 0 || cc <= 0) return;
    const double root = std::sqrt(disc);
    const double s_in = (-b - root) / a, s_out = (-b + root) / a;
    if (s_in <= 0 || s_in > max_s) return;
    Candidate c;
    c.s_in = s_in;
    c.s_out = s_out;
    c.z_bottom = cr.centre.z() - cr.radii_m.z();
    c.z_top = cr.centre.z() + cr.radii_m.z();
    c.surface_id = id;
    c.index = i;
    c.kind = SurfaceKind::crown;
    c.hx = ex;
    c.hy = ey;
    candidates_.push_back(c);
  }

  double ground_hit(double cos_el, double sin_el) const {
    const SceneGround& g = scene_.ground;
    const double denom = sin_el - cos_el * (g.slope_x * hx_ + g.slope_y * hy_);
    if (denom >= 0) return kInf;
    const double t = (ground_at_origin_ - origin_.z()) / denom;
    if (t <= 0) return kInf;
    const double x = origin_.x() + t * cos_el * hx_, y = origin_.y() + t * cos_el * hy_;
    if (std::abs(x) > g.half_size_m || std::abs(y) > g.half_size_m) return kInf;
    return t;
  }

  // Entry into the vertical extent [z_bottom, z_top] combined with the horizontal [s_in, s_out].
  bool slab_entry(const Candidate& c, double cos_el, double sin_el, double& t_in, bool& through_side) const {
    const double oz = origin_.z();
    double tz_in = -kInf, tz_out = kInf;
    if (sin_el > 0) {
      tz_in = (c.z_bottom - oz) / sin_el;
      tz_out = (c.z_top - oz) / sin_el;
    } else if (sin_el < 0) {
      tz_in = (c.z_top - oz) / sin_el;
      tz_out = (c.z_bottom - oz) / sin_el;
    } else if (oz < c.z_bottom || oz > c.z_top) {
      return false;
    }
    const double th_in = c.s_in / cos_el, th_out = c.s_out / cos_el;
    t_in = std::max(th_in, tz_in);
    through_side = th_in >= tz_in;
    return t_in <= std::min(th_out, tz_out) && t_in > 0;
  }

  double box_hit(const Candidate& c, double cos_el, double sin_el) const {
    double t_in = 0;
    bool through_side = false;
    if (!slab_entry(c, cos_el, sin_el, t_in, through_side)) return kInf;
    if (!through_side) return t_in;  // through the top (or bottom)
    if (c.face < 0) return kInf;     // cannot happen: it would start inside the box
    const SceneBox& b = scene_.boxes[c.index];
    const WindowGrid& g = b.windows[c.face];
    if (g.columns == 0) return t_in;
    const Eigen::Vector3d o = frames_[c.index].origin_local;
    const Eigen::Vector3d d(cos_el * c.hx, cos_el * c.hy, sin_el);
    const Eigen::Vector3d q = o + t_in * d;
    const Eigen::Vector3d& h = b.half_extent_m;
    const int normal_axis = c.face / 2, u_axis = 1 - normal_axis;
    const double u = q[u_axis] + h[u_axis] - g.u_first_m, z = q.z() + h.z() - g.z_first_m;
    if (u < 0 || z < 0) return t_in;
    const double col = std::floor(u / g.u_pitch_m), row = std::floor(z / g.z_pitch_m);
    if (col >= g.columns || row >= g.rows) return t_in;
    if (u - col * g.u_pitch_m > g.width_m || z - row * g.z_pitch_m > g.height_m) return t_in;
    // Inside a window opening: the ray goes on into the recess and stops at its back or side wall.
    const double sign = c.face % 2 == 0 ? 1.0 : -1.0;
    Eigen::Vector3d lo, hi;
    lo[normal_axis] = sign > 0 ? h[normal_axis] - g.depth_m : -h[normal_axis] - 0.5;
    hi[normal_axis] = sign > 0 ? h[normal_axis] + 0.5 : -h[normal_axis] + g.depth_m;
    lo[u_axis] = -h[u_axis] + g.u_first_m + col * g.u_pitch_m;
    hi[u_axis] = lo[u_axis] + g.width_m;
    lo[2] = -h.z() + g.z_first_m + row * g.z_pitch_m;
    hi[2] = lo[2] + g.height_m;
    return std::max(t_in, exit_distance(o, d, lo, hi));
  }

  double pole_hit(const Candidate& c, double cos_el, double sin_el) const {
    double t_in = 0;
    bool through_side = false;
    if (!slab_entry(c, cos_el, sin_el, t_in, through_side)) return kInf;
    return t_in;  // a cap entry (through_side false) lies inside the circle: slab_entry checked s <= s_out
  }

  double crown_hit(const Candidate& c, double cos_el, double sin_el, std::uint64_t ray_key) const {
    if (sin_el > 0 ? origin_.z() + c.s_in * sin_el / cos_el > c.z_top
                   : origin_.z() + c.s_in * sin_el / cos_el < c.z_bottom) {
      return kInf;
    }
    const SceneCrown& cr = scene_.crowns[c.index];
    const Eigen::Vector3d q = (origin_ - cr.centre).cwiseQuotient(cr.radii_m);
    const Eigen::Vector3d e(cos_el * c.hx, cos_el * c.hy, sin_el / cr.radii_m.z());
    const double a = e.squaredNorm(), b = q.dot(e), cc = q.squaredNorm() - 1.0;
    const double disc = b * b - a * cc;
    if (disc < 0) return kInf;
    const double root = std::sqrt(disc);
    const double t_in = (-b - root) / a, t_out = (-b + root) / a;
    if (t_in <= 0) return kInf;
    const std::uint64_t word = splitmix64(ray_key ^ (0xD6E8FEB86659FD93ULL * (c.surface_id + 1ULL)));
    if (unit(word) < cr.gap_fraction) return kInf;
    return t_in + unit(splitmix64(word)) * std::min(cr.foliage_depth_m, t_out - t_in);
  }

  const CityScene& scene_;
  Eigen::Vector3d origin_;
  double ground_at_origin_ = 0;
  std::vector<BoxFrame> frames_;
  double hx_ = 1, hy_ = 0;
  std::vector<Candidate> candidates_;
  std::vector<double> steepest_after_;
};

struct Grid {
  std::size_t columns, rows;
};

Grid grid_of(const ScannerSettings& s) {
  if (!(s.angular_step_deg > 0) || !std::isfinite(s.angular_step_deg)) {
    throw InputError("scanner angular step must be > 0 degrees, got " + std::to_string(s.angular_step_deg));
  }
  if (!(s.min_elevation_deg <= s.max_elevation_deg) || s.min_elevation_deg <= -90 || s.max_elevation_deg >= 90) {
    throw InputError("scanner elevation range must satisfy -90 < min <= max < 90 degrees");
  }
  if (!(s.min_range_m >= 0) || !(s.min_range_m < s.max_range_m) || !(s.range_noise_sigma_m >= 0)) {
    throw InputError("scanner range window must satisfy 0 <= min < max and noise sigma >= 0");
  }
  const double columns = std::floor(360.0 / s.angular_step_deg + 1e-9);
  const double rows = std::floor((s.max_elevation_deg - s.min_elevation_deg) / s.angular_step_deg + 1e-9) + 1;
  if (columns * rows > 4.0e9) throw InputError("scanner angular step too small: more than 4e9 rays");
  return {static_cast<std::size_t>(std::max(columns, 1.0)), static_cast<std::size_t>(rows)};
}

}  // namespace

double max_range_noise_m(const ScannerSettings& settings) { return 2.0 * std::sqrt(3.0) * settings.range_noise_sigma_m; }

std::size_t ray_count(const ScannerSettings& settings) {
  const Grid g = grid_of(settings);
  return g.columns * g.rows;
}

Eigen::Matrix4d ScannerPose::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  m(0, 0) = c;
  m(0, 1) = -s;
  m(1, 0) = s;
  m(1, 1) = c;
  m.topRightCorner<3, 1>() = position;
  return m;
}

CityScan scan_city(const CityScene& scene, const ScannerPose& pose, const ScannerSettings& settings,
                   std::uint64_t seed, bool with_surface_ids) {
  const Grid grid = grid_of(settings);
  const double step_rad = settings.angular_step_deg * kPi / 180.0;
  const double min_el_rad = settings.min_elevation_deg * kPi / 180.0;
  const double noise_scale = std::sqrt(3.0) * settings.range_noise_sigma_m;
  const double max_t = settings.max_range_m + max_range_noise_m(settings);  // farther hits are dropped anyway

  std::vector<double> cos_el(grid.rows), sin_el(grid.rows), tan_el(grid.rows);
  for (std::size_t r = 0; r < grid.rows; ++r) {
    const double el = min_el_rad + static_cast<double>(r) * step_rad;
    cos_el[r] = std::cos(el);
    sin_el[r] = std::sin(el);
    tan_el[r] = sin_el[r] / cos_el[r];
  }
  const double cos_yaw = std::cos(pose.yaw_rad), sin_yaw = std::sin(pose.yaw_rad);
  const std::uint64_t seed_key = splitmix64(seed ^ 0x5CA1AB1E0C17E5ULL);

  Caster caster(scene, pose);
  std::vector<double> xyz;
  CityScan scan;
  scan.n_rays = grid.columns * grid.rows;
  for (std::size_t col = 0; col < grid.columns; ++col) {
    const double az = static_cast<double>(col) * step_rad;
    const double ca = std::cos(az), sa = std::sin(az);
    caster.prepare_column(cos_yaw * ca - sin_yaw * sa, sin_yaw * ca + cos_yaw * sa, max_t);
    for (std::size_t row = 0; row < grid.rows; ++row) {
      const std::uint64_t ray_key = splitmix64(seed_key + col * grid.rows + row);
      double t = 0;
      const std::uint32_t id = caster.cast(cos_el[row], sin_el[row], tan_el[row], ray_key, max_t, t);
      if (id == kNoHit) continue;
      const double range = t + noise_scale * irwin_hall4(splitmix64(ray_key), splitmix64(ray_key + 1));
      if (range < settings.min_range_m || range > settings.max_range_m) continue;
      xyz.push_back(range * cos_el[row] * ca);
      xyz.push_back(range * cos_el[row] * sa);
      xyz.push_back(range * sin_el[row]);
      if (with_surface_ids) scan.surface_ids.push_back(id);
    }
  }
  const auto n = static_cast<Eigen::Index>(xyz.size() / 3);
  scan.points = Eigen::Map<const Cloud>(xyz.data(), 3, n);
  scan.n_dropped = scan.n_rays - static_cast<std::size_t>(n);
  return scan;
}

}  // namespace nnb::datasets

#include "omnipoint/data/synth/intersect.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace omnipoint::data::synth {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// An opening of the box in column `column` of the batch being tested.
struct Hole {
  int64_t column;
  const PackedScene::PackedOpening* opening;
};

at::Tensor component(const at::Tensor& t, int64_t i) {
  return t.select(-1, i);
}

// Explicit three-term dot product over the last dimension (a fixed evaluation order,
// unlike a reduction kernel).
at::Tensor dot3(const at::Tensor& a, const at::Tensor& b) {
  return component(a, 0) * component(b, 0) + component(a, 1) * component(b, 1) +
         component(a, 2) * component(b, 2);
}

// Replaces |x| < tiny by +/-tiny so that 1/x stays finite and keeps its sign.
at::Tensor away_from_zero(const at::Tensor& x) {
  constexpr double tiny = 1e-12;
  return at::where(x >= 0, x.clamp_min(tiny), x.clamp_max(-tiny));
}

// The nearer of two candidate parameters, each usable only where `ok`.
at::Tensor first_valid(const at::Tensor& t0, const at::Tensor& ok0, const at::Tensor& t1,
                       const at::Tensor& ok1) {
  const auto inf = at::full({}, kInf, t0.options());
  return at::minimum(at::where(ok0, t0, inf), at::where(ok1, t1, inf));
}

// World vectors (..., 3) into the yawed local frames of boxes: Rz(-yaw) v.
at::Tensor to_local(const at::Tensor& v, const at::Tensor& c, const at::Tensor& s) {
  const auto x = component(v, 0), y = component(v, 1);
  return at::stack({c * x + s * y, c * y - s * x, component(v, 2)}, -1);
}

at::Tensor intersect_planes(const PackedScene& ps, const at::Tensor& idx, const at::Tensor& o,
                            const at::Tensor& d, double t_min, const std::vector<Hole>&) {
  const auto n = ps.axis.index_select(0, idx).unsqueeze(0);  // (1, M, 3)
  const auto c = ps.center.index_select(0, idx).unsqueeze(0);
  const auto nd = dot3(d.unsqueeze(1), n);  // (N, M)
  const auto t = dot3(c - o.unsqueeze(1), n) / away_from_zero(nd);
  return at::where((nd.abs() > 1e-12) & (t > t_min), t, at::full({}, kInf, t.options()));
}

at::Tensor intersect_boxes(const PackedScene& ps, const at::Tensor& idx, const at::Tensor& o,
                           const at::Tensor& d, double t_min, const std::vector<Hole>& holes) {
  const auto c = ps.center.index_select(0, idx).unsqueeze(0);  // (1, M, 3)
  const auto h = ps.half_size.index_select(0, idx).unsqueeze(0);
  const auto cy = ps.yaw_cos.index_select(0, idx).unsqueeze(0);  // (1, M)
  const auto sy = ps.yaw_sin.index_select(0, idx).unsqueeze(0);
  const auto ol = to_local(o.unsqueeze(1) - c, cy, sy);  // (N, M, 3)
  const auto dl = to_local(d.unsqueeze(1).expand({d.size(0), idx.size(0), 3}), cy, sy);
  const auto inv = at::reciprocal(away_from_zero(dl));
  const auto t1 = (-h - ol) * inv, t2 = (h - ol) * inv;
  const auto t_near = std::get<0>(at::minimum(t1, t2).max(-1));
  const auto t_far = std::get<0>(at::maximum(t1, t2).min(-1));
  const auto crosses = t_near <= t_far;
  auto ok_near = crosses & (t_near > t_min);
  auto ok_far = crosses & (t_far > t_min);
  // A surface point inside an opening is no surface: the ray passes through the hole.
  for (const auto& hole : holes) {
    const auto& packed = *hole.opening;
    const auto& op = packed.opening;
    const int a0 = op.axis == 0 ? 1 : 0, a1 = op.axis == 2 ? 1 : 2;
    const auto olm = ol.select(1, hole.column), dlm = dl.select(1, hole.column);
    const double face = packed.face;
    const double tolerance = 1e-4 * (1.0 + std::abs(face));
    for (auto* which : {&ok_near, &ok_far}) {
      const auto& t = which == &ok_near ? t_near : t_far;
      const auto tm = t.select(1, hole.column).unsqueeze(-1);
      const auto p = olm + tm * dlm;  // (N, 3)
      const auto pa = component(p, op.axis), p0 = component(p, a0), p1 = component(p, a1);
      const auto in_hole = ((pa - face).abs() <= tolerance) & (p0 >= op.lo[0]) & (p0 <= op.hi[0]) &
                           (p1 >= op.lo[1]) & (p1 <= op.hi[1]);
      which->select(1, hole.column).logical_and_(in_hole.logical_not());
    }
  }
  return first_valid(t_near, ok_near, t_far, ok_far);
}

at::Tensor intersect_spheres(const PackedScene& ps, const at::Tensor& idx, const at::Tensor& o,
                             const at::Tensor& d, double t_min, const std::vector<Hole>&) {
  const auto c = ps.center.index_select(0, idx).unsqueeze(0);
  const auto r = ps.radius.index_select(0, idx).unsqueeze(0);  // (1, M)
  const auto w = o.unsqueeze(1) - c;                           // (N or 1, M, 3)
  const auto b = dot3(w, d.unsqueeze(1));                      // (N, M)
  const auto disc = b * b - (dot3(w, w) - r * r);
  const auto root = at::sqrt(disc.clamp_min(0));
  const auto hits = disc >= 0;
  const auto t0 = -b - root, t1 = -b + root;
  return first_valid(t0, hits & (t0 > t_min), t1, hits & (t1 > t_min));
}

at::Tensor intersect_cylinders(const PackedScene& ps, const at::Tensor& idx, const at::Tensor& o,
                               const at::Tensor& d, double t_min, const std::vector<Hole>&) {
  const auto c = ps.center.index_select(0, idx).unsqueeze(0);
  const auto a = ps.axis.index_select(0, idx).unsqueeze(0);    // (1, M, 3)
  const auto r = ps.radius.index_select(0, idx).unsqueeze(0);  // (1, M)
  const auto hl = component(ps.half_size.index_select(0, idx), 2).unsqueeze(0);
  const auto w = o.unsqueeze(1) - c;
  const auto de = d.unsqueeze(1);
  const auto wa = dot3(w, a), da = dot3(de, a);  // (N, M)
  const auto wp = w - wa.unsqueeze(-1) * a, dp = de - da.unsqueeze(-1) * a;
  const auto qa = dot3(dp, dp), qb = dot3(wp, dp), qc = dot3(wp, wp) - r * r;
  const auto disc = qb * qb - qa * qc;
  const auto root = at::sqrt(disc.clamp_min(0));
  const auto qa_safe = qa.clamp_min(1e-12);
  const auto side_ok = (disc >= 0) & (qa > 1e-12);
  const auto s0 = (-qb - root) / qa_safe, s1 = (-qb + root) / qa_safe;
  const auto within = [&](const at::Tensor& t) { return (wa + t * da).abs() <= hl; };
  auto t =
      first_valid(s0, side_ok & (s0 > t_min) & within(s0), s1, side_ok & (s1 > t_min) & within(s1));
  const auto da_safe = away_from_zero(da);
  for (double sign : {-1.0, 1.0}) {
    const auto tc = (sign * hl - wa) / da_safe;
    const auto q = wp + tc.unsqueeze(-1) * dp;
    const auto ok = (da.abs() > 1e-12) & (tc > t_min) & (dot3(q, q) <= r * r);
    t = at::minimum(t, at::where(ok, tc, at::full({}, kInf, tc.options())));
  }
  return t;
}

using Intersector = at::Tensor (*)(const PackedScene&, const at::Tensor&, const at::Tensor&,
                                   const at::Tensor&, double, const std::vector<Hole>&);
constexpr Intersector kIntersectors[kNumShapes] = {intersect_planes, intersect_boxes,
                                                   intersect_spheres, intersect_cylinders};

// Texture coordinates from a local position q and local normal n: the two coordinates
// across the dominant normal axis. The vertical coordinate stays world height `z` so that
// bricks, floors of windows etc. line up with the ground.
at::Tensor dominant_axis_uv(const at::Tensor& q, const at::Tensor& n, const at::Tensor& z) {
  const auto ax = component(n, 0).abs(), ay = component(n, 1).abs(), az = component(n, 2).abs();
  const auto x_dominant = (ax >= ay) & (ax >= az);
  const auto y_dominant = x_dominant.logical_not() & (ay >= az);
  const auto u = at::where(x_dominant, component(q, 1), component(q, 0));
  const auto v = at::where(x_dominant | y_dominant, z, component(q, 1));
  return at::stack({u, v}, -1);
}

at::Tensor normalized(const at::Tensor& v) {
  return v / at::sqrt(dot3(v, v)).clamp_min(1e-20).unsqueeze(-1);
}

}  // namespace

PackedScene pack_scene(const Scene& scene, const at::TensorOptions& options) {
  const auto count = static_cast<int64_t>(scene.primitives.size());
  std::vector<int64_t> shape, material;
  std::vector<double> center, half, ycos, ysin, axis, radius;
  PackedScene ps;
  for (int64_t i = 0; i < count; ++i) {
    const auto& p = scene.primitives[i];
    const auto s = static_cast<int64_t>(p.shape);
    shape.push_back(s);
    material.push_back(p.material);
    center.insert(center.end(), p.center.begin(), p.center.end());
    half.insert(half.end(), p.half_size.begin(), p.half_size.end());
    ycos.push_back(std::cos(p.yaw));
    ysin.push_back(std::sin(p.yaw));
    axis.insert(axis.end(), p.axis.begin(), p.axis.end());
    radius.push_back(p.radius);
    for (const auto& op : p.openings)
      ps.openings.push_back({i, op.side * p.half_size[op.axis], op});
    ps.shapes.push_back(p.shape);
    ps.bound_centers.push_back(p.center);
    const auto& h = p.half_size;
    switch (p.shape) {
      case Shape::kPlane:
        ps.bound_radii.push_back(kInf);
        break;
      case Shape::kBox:
        ps.bound_radii.push_back(std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]));
        break;
      case Shape::kSphere:
        ps.bound_radii.push_back(p.radius);
        break;
      case Shape::kCylinder:
        ps.bound_radii.push_back(std::hypot(p.radius, h[2]));
        break;
    }
  }
  const auto f64 = at::TensorOptions().dtype(at::kDouble);
  const auto i64 = at::TensorOptions().dtype(at::kLong);
  const auto put = [&](std::vector<double>& v, int64_t cols) {
    auto t = at::tensor(v, f64);
    if (cols > 1) t = t.reshape({count, cols});
    return t.to(options);
  };
  ps.shape = at::tensor(shape, i64).to(options.device());
  ps.material = at::tensor(material, i64).to(options.device());
  ps.center = put(center, 3);
  ps.half_size = put(half, 3);
  ps.yaw_cos = put(ycos, 1);
  ps.yaw_sin = put(ysin, 1);
  ps.axis = put(axis, 3);
  ps.radius = put(radius, 1);
  return ps;
}

Hit nearest_hit(const PackedScene& ps, const Candidates& candidates, const at::Tensor& origins,
                const at::Tensor& directions, double t_min) {
  const auto n = directions.size(0);
  Hit hit{at::full({n}, kInf, directions.options()),
          at::full({n}, -1, directions.options().dtype(at::kLong))};
  std::array<std::vector<int64_t>, kNumShapes> of_shape;
  std::vector<Hole> holes;
  for (const int64_t i : candidates) {
    const auto s = static_cast<int>(ps.shapes[i]);
    for (const auto& op : ps.openings)
      if (op.primitive == i) holes.push_back({static_cast<int64_t>(of_shape[s].size()), &op});
    of_shape[s].push_back(i);
  }
  for (int s = 0; s < kNumShapes; ++s) {
    if (of_shape[s].empty()) continue;
    const auto idx =
        at::tensor(of_shape[s], at::TensorOptions().dtype(at::kLong)).to(directions.device());
    const auto t_all = kIntersectors[s](ps, idx, origins, directions, t_min, holes);  // (N, M)
    const auto [t, column] = t_all.min(1);
    const auto nearer = t < hit.t;
    hit.t = at::where(nearer, t, hit.t);
    hit.primitive = at::where(nearer, idx.index_select(0, column), hit.primitive);
  }
  return hit;
}

Surface surface_at(const PackedScene& ps, const at::Tensor& p, const at::Tensor& primitive) {
  const auto shape = ps.shape.index_select(0, primitive);
  const auto c = ps.center.index_select(0, primitive);
  const auto h = ps.half_size.index_select(0, primitive);
  const auto cy = ps.yaw_cos.index_select(0, primitive);
  const auto sy = ps.yaw_sin.index_select(0, primitive);
  const auto a = ps.axis.index_select(0, primitive);
  const auto r = ps.radius.index_select(0, primitive);
  const auto z = component(p, 2);
  const auto w = p - c;

  // Box: the face whose slab the point lies on is the axis with the largest |q| / h.
  const auto q = to_local(w, cy, sy);
  const auto ratio = q.abs() / h;
  const auto rx = component(ratio, 0), ry = component(ratio, 1), rz = component(ratio, 2);
  const auto on_x = (rx >= ry) & (rx >= rz);
  const auto on_y = on_x.logical_not() & (ry >= rz);
  const auto on_z = (on_x | on_y).logical_not();
  const auto sign = at::sign(q);
  const auto local_n = at::stack({at::where(on_x, component(sign, 0), at::zeros_like(rx)),
                                  at::where(on_y, component(sign, 1), at::zeros_like(rx)),
                                  at::where(on_z, component(sign, 2), at::zeros_like(rx))},
                                 -1);
  const auto lx = component(local_n, 0), ly = component(local_n, 1);
  const auto box_n = at::stack({cy * lx - sy * ly, sy * lx + cy * ly, component(local_n, 2)}, -1);
  const auto box_uv = dominant_axis_uv(q, local_n, z);

  // Cylinder: cap or side, whichever surface the point is closer to.
  const auto wa = dot3(w, a);
  const auto radial = w - wa.unsqueeze(-1) * a;
  const auto rho = at::sqrt(dot3(radial, radial));
  const auto on_cap = (component(h, 2) - wa.abs()) < (r - rho);
  const auto cyl_n = at::where(on_cap.unsqueeze(-1), at::sign(wa).unsqueeze(-1) * a,
                               radial / rho.clamp_min(1e-20).unsqueeze(-1));

  const auto sphere_n = normalized(w);
  const auto is = [&](Shape s) { return (shape == static_cast<int64_t>(s)).unsqueeze(-1); };
  auto normal =
      at::where(is(Shape::kBox), box_n,
                at::where(is(Shape::kSphere), sphere_n, at::where(is(Shape::kCylinder), cyl_n, a)));
  const auto plane_q = p;  // planes are textured in world coordinates
  const auto round_uv = dominant_axis_uv(w, normal, z);
  auto uv = at::where(is(Shape::kBox), box_uv,
                      at::where(is(Shape::kPlane), dominant_axis_uv(plane_q, normal, z), round_uv));
  return Surface{normal, uv, ps.material.index_select(0, primitive)};
}

}  // namespace omnipoint::data::synth

namespace omnipoint::data::synth {
namespace {

double distance(const Vec3& a, const Vec3& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}

// Distance from p to the segment from a along unit u of length `length` (may be inf).
double distance_to_path(const Vec3& p, const Vec3& a, const Vec3& u, double length) {
  const Vec3 v{p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  const double s = std::clamp(v[0] * u[0] + v[1] * u[1] + v[2] * u[2], 0.0, length);
  return distance(p, {a[0] + s * u[0], a[1] + s * u[1], a[2] + s * u[2]});
}

template <typename Keep>
Candidates select(const PackedScene& ps, Keep keep) {
  Candidates out;
  for (int64_t i = 0; i < static_cast<int64_t>(ps.shapes.size()); ++i)
    if (std::isinf(ps.bound_radii[i]) || keep(ps.bound_centers[i], ps.bound_radii[i]))
      out.push_back(i);
  return out;
}

}  // namespace

Candidates candidates_in_cone(const PackedScene& ps, const Vec3& origin, const Vec3& axis,
                              double cos_half_angle) {
  const double half_angle = std::acos(std::clamp(cos_half_angle, -1.0, 1.0));
  return select(ps, [&](const Vec3& c, double r) {
    const double d = distance(c, origin);
    if (d <= r * (1 + 1e-9) + 1e-9) return true;
    const double along = ((c[0] - origin[0]) * axis[0] + (c[1] - origin[1]) * axis[1] +
                          (c[2] - origin[2]) * axis[2]) /
                         d;
    const double angle = std::acos(std::clamp(along, -1.0, 1.0));
    return angle <= half_angle + std::asin(std::min(1.0, r / d)) + 1e-6;
  });
}

Candidates candidates_near_path(const PackedScene& ps, const Vec3& center, double radius,
                                const Vec3& target, bool towards_infinity) {
  Vec3 u = target;
  double length = kInf;
  if (!towards_infinity) {
    length = distance(target, center);
    u = length > 0 ? Vec3{(target[0] - center[0]) / length, (target[1] - center[1]) / length,
                          (target[2] - center[2]) / length}
                   : Vec3{0, 0, 1};
  }
  return select(ps, [&](const Vec3& c, double r) {
    return distance_to_path(c, center, u, length) <= radius + r + 1e-6;
  });
}

Candidates candidates_within(const PackedScene& ps, const Vec3& center, double radius,
                             double reach) {
  return select(ps, [&](const Vec3& c, double r) {
    return distance(c, center) <= radius + reach + r + 1e-6;
  });
}

}  // namespace omnipoint::data::synth

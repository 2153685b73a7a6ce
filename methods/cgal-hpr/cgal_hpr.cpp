// CGAL peer for pointsight (external-method protocol 1, 2 or 3, methods/README.md): Hidden Point
// Removal (Katz, Tal & Basri 2007) with CGAL's exact-predicate hull. Per view: translate to the
// eye C, flip every point exactly as pointsight's `hpr` crate does (p^ = v * ((2R - |v|) / |v|),
// v = p - C, |v| = sqrt(x*x + y*y + z*z), R = max|v| * 10^gamma, or `radius`), then
// CGAL::extreme_points_3 (the vertices of convex_hull_3, exact predicates, Epick) over the
// flipped points plus C; the visible points are the extreme ones other than C, every copy of a
// coincident input point included (as pointsight's hpr). Built without FMA contraction so the
// flipped coordinates are bit-identical to pointsight's.
//
// One process serves every setting: each request's setting (`gamma`, default 3, or `radius`)
// is its "params" (protocol 3), else --params (protocols 1 and 2). The points and their
// coincident groups are read and found once, at start.
//
// The protocol's arguments, points file and loop: ../_shared/pointsight_protocol.hpp.
//
// Usage: cgal_hpr --points FILE --protocol 3 [--normals W] [--spacing S]   (views on stdin)
//        cgal_hpr --points FILE --params JSON --protocol 1|2 [--normals W] [--spacing S]
//        cgal_hpr --version
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Extreme_points_traits_adapter_3.h>
#include <CGAL/convex_hull_3.h>
#include <CGAL/version.h>
#include <boost/property_map/property_map.hpp>

#include "../_shared/pointsight_protocol.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

typedef CGAL::Exact_predicates_inexact_constructions_kernel K;
typedef K::Point_3 Point_3;

namespace protocol = pointsight_protocol;

int main(int argc, char** argv) {
  protocol::Args args = protocol::parse_args(argc, argv);
  if (args.version) {
    std::printf("CGAL %s\n", CGAL_VERSION_STR);
    return 0;
  }
  try {
    if (args.points.empty()) throw std::runtime_error("no --points");
    struct {
      std::vector<double> xyz;  // 3 per point
      size_t n = 0;
    } c;
    c.xyz = protocol::read_xyz(args.points);
    c.n = c.xyz.size() / 3;
    if (c.n == 0) throw std::runtime_error("the point cloud is empty");
    // Coincident input points: each index's group leader (lowest index with equal xyz).
    std::vector<uint32_t> order(c.n), leader(c.n);
    for (size_t i = 0; i < c.n; ++i) order[i] = uint32_t(i);
    auto less = [&](uint32_t a, uint32_t b) {
      for (int d = 0; d < 3; ++d)
        if (c.xyz[3 * a + d] != c.xyz[3 * b + d]) return c.xyz[3 * a + d] < c.xyz[3 * b + d];
      return a < b;
    };
    std::sort(order.begin(), order.end(), less);
    std::vector<std::vector<uint32_t>> groups;  // only groups of more than one
    std::vector<int64_t> group_of(c.n, -1);
    for (size_t s = 0; s < c.n;) {
      size_t e = s + 1;
      while (e < c.n && std::equal(&c.xyz[3 * order[s]], &c.xyz[3 * order[s]] + 3,
                                   &c.xyz[3 * order[e]]))
        ++e;
      if (e - s > 1) {
        std::vector<uint32_t> g(order.begin() + s, order.begin() + e);
        for (uint32_t i : g) group_of[i] = int64_t(groups.size());
        groups.push_back(g);
      }
      s = e;
    }
    std::vector<Point_3> flipped(c.n + 1);
    std::vector<std::size_t> indices(c.n + 1);
    for (size_t i = 0; i <= c.n; ++i) indices[i] = i;
    protocol::serve([&](const std::string&, const double eye[3], const std::string& params) {
      // The setting: R = `radius`, else max|v| * 10^`gamma`.
      double gamma = 3.0, radius = 0.0;
      bool absolute = protocol::param_number(params, "radius", radius);
      protocol::param_number(params, "gamma", gamma);
      auto t0 = std::chrono::steady_clock::now();
      double maxd = 0.0;
      std::vector<double> d(c.n);
      bool bad = false;
      for (size_t i = 0; i < c.n; ++i) {
        double x = c.xyz[3 * i] - eye[0], y = c.xyz[3 * i + 1] - eye[1],
               z = c.xyz[3 * i + 2] - eye[2];
        d[i] = std::sqrt(x * x + y * y + z * z);
        if (!(d[i] > 0.0) || !std::isfinite(d[i])) bad = true;
        maxd = std::max(maxd, d[i]);
      }
      double r = absolute ? radius : maxd * std::pow(10.0, gamma);
      if (bad || !(r > maxd)) {
        protocol::send_error(bad
                                 ? "the viewpoint coincides with a point or a coordinate is not finite"
                                 : "R does not exceed the farthest point's distance");
        return;
      }
      for (size_t i = 0; i < c.n; ++i) {
        double x = c.xyz[3 * i] - eye[0], y = c.xyz[3 * i + 1] - eye[1],
               z = c.xyz[3 * i + 2] - eye[2];
        double f = (2.0 * r - d[i]) / d[i];
        flipped[i] = Point_3(x * f, y * f, z * f);
      }
      flipped[c.n] = Point_3(0.0, 0.0, 0.0);
      std::vector<std::size_t> extreme;
      CGAL::extreme_points_3(
          indices, std::back_inserter(extreme),
          CGAL::make_extreme_points_traits_adapter(
              CGAL::make_property_map(flipped)));
      std::vector<uint32_t> visible;
      visible.reserve(extreme.size());
      for (std::size_t i : extreme) {
        if (i == c.n) continue;
        if (group_of[i] >= 0) {
          for (uint32_t j : groups[size_t(group_of[i])]) visible.push_back(j);
        } else {
          visible.push_back(uint32_t(i));
        }
      }
      std::sort(visible.begin(), visible.end());
      visible.erase(std::unique(visible.begin(), visible.end()), visible.end());
      double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      protocol::send_visible(visible, "", seconds);
    }, args.params);
  } catch (const std::exception& e) {
    protocol::send_error(e.what());
    std::fprintf(stderr, "cgal_hpr: %s\n", e.what());
    return 2;
  }
  return 0;
}

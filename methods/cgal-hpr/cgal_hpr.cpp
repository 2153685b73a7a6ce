// CGAL peer for pointsight (external-method protocol 1 or 2, methods/README.md): Hidden Point
// Removal (Katz, Tal & Basri 2007) with CGAL's exact-predicate hull. Per view: translate to the
// eye C, flip every point exactly as pointsight's `hpr` crate does (p^ = v * ((2R - |v|) / |v|),
// v = p - C, |v| = sqrt(x*x + y*y + z*z), R = max|v| * 10^gamma, or `radius`), then
// CGAL::extreme_points_3 (the vertices of convex_hull_3, exact predicates, Epick) over the
// flipped points plus C; the visible points are the extreme ones other than C, every copy of a
// coincident input point included (as pointsight's hpr). Built without FMA contraction so the
// flipped coordinates are bit-identical to pointsight's.
//
// Usage: cgal_hpr --points FILE --params JSON --protocol P [--normals W]   (views on stdin)
//        cgal_hpr --version
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Extreme_points_traits_adapter_3.h>
#include <CGAL/convex_hull_3.h>
#include <CGAL/version.h>
#include <boost/property_map/property_map.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

typedef CGAL::Exact_predicates_inexact_constructions_kernel K;
typedef K::Point_3 Point_3;

struct Cloud {
  std::vector<double> xyz;  // 3 per point
  size_t n = 0;
};

static size_t type_size(const std::string& t) {
  if (t == "double" || t == "float64") return 8;
  if (t == "float" || t == "float32" || t == "int" || t == "uint" || t == "int32" ||
      t == "uint32")
    return 4;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  throw std::runtime_error("unknown PLY property type " + t);
}

// Reads the binary little-endian PLY pointsight writes: x y z doubles first, then any other
// properties (normals, colours, uv) which are skipped.
static Cloud read_points(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot open " + path);
  std::string line;
  size_t n = 0, stride = 0;
  std::vector<std::pair<std::string, size_t>> props;
  bool in_vertex = false;
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::string w;
    s >> w;
    if (w == "format") {
      std::string fmt;
      s >> fmt;
      if (fmt != "binary_little_endian") throw std::runtime_error("PLY is not binary LE");
    } else if (w == "element") {
      std::string e;
      s >> e;
      in_vertex = e == "vertex";
      if (in_vertex) s >> n;
    } else if (w == "property" && in_vertex) {
      std::string t, name;
      s >> t >> name;
      if (t == "list") throw std::runtime_error("list property in vertex element");
      props.push_back({name, stride});
      if ((name == "x" || name == "y" || name == "z") && type_size(t) != 8)
        throw std::runtime_error("coordinates are not doubles");
      stride += type_size(t);
    } else if (w == "end_header") {
      break;
    }
  }
  if (props.size() < 3 || props[0].first != "x" || props[1].first != "y" ||
      props[2].first != "z" || props[1].second != 8 || props[2].second != 16)
    throw std::runtime_error("vertex element does not start with double x y z");
  if (n > (size_t(1) << 32)) throw std::runtime_error("absurd vertex count");
  Cloud c;
  c.n = n;
  c.xyz.resize(3 * n);
  std::vector<char> row(stride);
  for (size_t i = 0; i < n; ++i) {
    if (!f.read(row.data(), stride)) throw std::runtime_error("PLY body is short");
    std::memcpy(&c.xyz[3 * i], row.data(), 24);
  }
  return c;
}

// The number after "key": in a flat JSON object (quoted or not), else `fallback`.
static bool json_number(const std::string& json, const std::string& key, double& out) {
  std::string k = "\"" + key + "\"";
  size_t p = json.find(k);
  if (p == std::string::npos) return false;
  p = json.find(':', p + k.size());
  if (p == std::string::npos) return false;
  ++p;
  while (p < json.size() && (json[p] == ' ' || json[p] == '"')) ++p;
  char* end = nullptr;
  out = std::strtod(json.c_str() + p, &end);
  return end != json.c_str() + p;
}

static bool json_triple(const std::string& json, const std::string& key, double out[3]) {
  std::string k = "\"" + key + "\"";
  size_t p = json.find(k);
  if (p == std::string::npos) return false;
  p = json.find('[', p + k.size());
  if (p == std::string::npos) return false;
  const char* s = json.c_str() + p + 1;
  for (int i = 0; i < 3; ++i) {
    char* end = nullptr;
    out[i] = std::strtod(s, &end);
    if (end == s) return false;
    s = end;
    while (*s == ' ' || *s == ',') ++s;
  }
  return true;
}

static std::string escape(const std::string& s) {
  std::string o;
  for (char ch : s) {
    if (ch == '"' || ch == '\\') o += '\\';
    if (ch == '\n') { o += "\\n"; continue; }
    o += ch;
  }
  return o;
}

int main(int argc, char** argv) {
  std::string points, params = "{}";
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--version") {
      std::printf("CGAL %s\n", CGAL_VERSION_STR);
      return 0;
    }
    if (i + 1 < argc && a == "--points") points = argv[++i];
    else if (i + 1 < argc && a == "--params") params = argv[++i];
    else if (i + 1 < argc && (a == "--protocol" || a == "--normals")) ++i;
  }
  try {
    if (points.empty()) throw std::runtime_error("no --points");
    double gamma = 3.0, radius = 0.0;
    bool absolute = json_number(params, "radius", radius);
    json_number(params, "gamma", gamma);
    Cloud c = read_points(points);
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
    std::string line;
    while (std::getline(std::cin, line)) {
      double eye[3];
      if (!json_triple(line, "eye", eye)) {
        std::printf("{\"error\":\"request has no camera eye\"}\n");
        std::fflush(stdout);
        continue;
      }
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
        std::printf("{\"error\":\"%s\"}\n",
                    bad ? "the viewpoint coincides with a point or a coordinate is not finite"
                        : "R does not exceed the farthest point's distance");
        std::fflush(stdout);
        continue;
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
      std::string out = "{\"visible\":[";
      for (size_t k = 0; k < visible.size(); ++k) {
        if (k) out += ',';
        out += std::to_string(visible[k]);
      }
      char tail[64];
      std::snprintf(tail, sizeof tail, "],\"seconds\":%.9g}\n", seconds);
      out += tail;
      std::fwrite(out.data(), 1, out.size(), stdout);
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::printf("{\"error\":\"%s\"}\n", escape(e.what()).c_str());
    std::fflush(stdout);
    std::fprintf(stderr, "cgal_hpr: %s\n", e.what());
    return 2;
  }
  return 0;
}

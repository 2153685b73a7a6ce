// PCL peer for pointsight (external-method protocol 1 or 2, methods/README.md): voxel
// occlusion with pcl::VoxelGridOcclusionEstimation<pcl::PointXYZ>. Per view the cloud's
// sensor origin is set to the eye and the voxel grid (leaf = `leaf_factor` density spacings,
// or `leaf_size` world units) is initialised; each occupied voxel is then asked
// occlusionEstimation (PCL's ray traversal from the eye to the voxel's centre: occluded when an
// occupied voxel lies before it); the visible points are those in voxels not occluded. The
// answer also lists the occluded voxels' grid coordinates (`occluded_voxels`, PCL's
// floor(x / leaf) coordinates) for the accuracy gate.
//
// What users of PCL get is what this measures, bugs included: the traversal's octant handling
// and rounding (PCL issues #2046 and #5941) are PCL's, not corrected here. Points are floats
// (pcl::PointXYZ), as PCL stores them.
//
// Usage: pcl_voxel --points FILE --params JSON --protocol P [--normals W] [--spacing S]
//        pcl_voxel --version
#include <pcl/filters/voxel_grid_occlusion_estimation.h>
#include <pcl/pcl_config.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

static size_t type_size(const std::string& t) {
  if (t == "double" || t == "float64") return 8;
  if (t == "float" || t == "float32" || t == "int" || t == "uint" || t == "int32" ||
      t == "uint32")
    return 4;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  throw std::runtime_error("unknown PLY property type " + t);
}

// x y z doubles first (pointsight's binary little-endian PLY), other properties skipped.
static std::vector<double> read_points(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot open " + path);
  std::string line;
  size_t n = 0, stride = 0, props = 0;
  bool in_vertex = false;
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::string w;
    s >> w;
    if (w == "element") {
      std::string e;
      s >> e;
      in_vertex = e == "vertex";
      if (in_vertex) s >> n;
    } else if (w == "property" && in_vertex) {
      std::string t, name;
      s >> t >> name;
      if (props < 3 && (name != std::string(1, char('x' + props)) || type_size(t) != 8))
        throw std::runtime_error("vertex element does not start with double x y z");
      ++props;
      stride += type_size(t);
    } else if (w == "end_header") {
      break;
    }
  }
  if (props < 3) throw std::runtime_error("no x y z");
  if (n > (size_t(1) << 32)) throw std::runtime_error("absurd vertex count");
  std::vector<double> xyz(3 * n);
  std::vector<char> row(stride);
  for (size_t i = 0; i < n; ++i) {
    if (!f.read(row.data(), stride)) throw std::runtime_error("PLY body is short");
    std::memcpy(&xyz[3 * i], row.data(), 24);
  }
  return xyz;
}

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

int main(int argc, char** argv) {
  std::string points, params = "{}";
  double spacing = 0.0;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--version") {
      std::printf("PCL %s\n", PCL_VERSION_PRETTY);
      return 0;
    }
    if (i + 1 < argc && a == "--points") points = argv[++i];
    else if (i + 1 < argc && a == "--params") params = argv[++i];
    else if (i + 1 < argc && a == "--spacing") spacing = std::strtod(argv[++i], nullptr);
    else if (i + 1 < argc && (a == "--protocol" || a == "--normals")) ++i;
  }
  try {
    if (points.empty()) throw std::runtime_error("no --points");
    double leaf = 0.0, factor = 2.0;
    if (!json_number(params, "leaf_size", leaf)) {
      json_number(params, "leaf_factor", factor);
      if (!(spacing > 0.0))
        throw std::runtime_error("no --spacing sent (protocol 1, or <= 8 points): give leaf_size");
      leaf = factor * spacing;
    }
    if (!(leaf > 0.0) || !std::isfinite(leaf)) throw std::runtime_error("leaf size must be > 0");
    std::vector<double> xyz = read_points(points);
    size_t n = xyz.size() / 3;
    if (n == 0) throw std::runtime_error("the point cloud is empty");
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->resize(n);
    for (size_t i = 0; i < n; ++i)
      (*cloud)[i] = pcl::PointXYZ(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2]));
    float lf = float(leaf);
    std::string line;
    while (std::getline(std::cin, line)) {
      double eye[3];
      if (!json_triple(line, "eye", eye)) {
        std::printf("{\"error\":\"request has no camera eye\"}\n");
        std::fflush(stdout);
        continue;
      }
      auto t0 = std::chrono::steady_clock::now();
      cloud->sensor_origin_ = Eigen::Vector4f(float(eye[0]), float(eye[1]), float(eye[2]), 0.f);
      pcl::VoxelGridOcclusionEstimation<pcl::PointXYZ> grid;
      grid.setInputCloud(cloud);
      grid.setLeafSize(lf, lf, lf);
      grid.initializeVoxelGrid();
      std::map<std::tuple<int, int, int>, int> state;  // voxel -> occluded (1) or not (0)
      std::vector<uint32_t> visible;
      std::vector<std::tuple<int, int, int>> occluded;
      for (size_t i = 0; i < n; ++i) {
        const pcl::PointXYZ& p = (*cloud)[i];
        Eigen::Vector3i ijk = grid.getGridCoordinates(p.x, p.y, p.z);
        auto key = std::make_tuple(ijk[0], ijk[1], ijk[2]);
        auto it = state.find(key);
        if (it == state.end()) {
          int s = 0;
          grid.occlusionEstimation(s, ijk);
          it = state.emplace(key, s).first;
          if (s != 0) occluded.push_back(key);
        }
        if (it->second == 0) visible.push_back(uint32_t(i));
      }
      double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::string out = "{\"visible\":[";
      for (size_t k = 0; k < visible.size(); ++k) {
        if (k) out += ',';
        out += std::to_string(visible[k]);
      }
      out += "],\"occluded_voxels\":[";
      std::sort(occluded.begin(), occluded.end());
      for (size_t k = 0; k < occluded.size(); ++k) {
        if (k) out += ',';
        out += "[" + std::to_string(std::get<0>(occluded[k])) + "," +
               std::to_string(std::get<1>(occluded[k])) + "," +
               std::to_string(std::get<2>(occluded[k])) + "]";
      }
      char tail[96];
      std::snprintf(tail, sizeof tail, "],\"leaf\":%.9g,\"seconds\":%.9g}\n", leaf, seconds);
      out += tail;
      std::fwrite(out.data(), 1, out.size(), stdout);
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::string msg = e.what();
    std::replace(msg.begin(), msg.end(), '"', '\'');
    std::printf("{\"error\":\"%s\"}\n", msg.c_str());
    std::fflush(stdout);
    std::fprintf(stderr, "pcl_voxel: %s\n", e.what());
    return 2;
  }
  return 0;
}

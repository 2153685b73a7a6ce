// PCL peer for pointsight (external-method protocol 1, 2 or 3, methods/README.md): voxel
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
// One process serves every setting: each request's setting (`leaf_size`, else `leaf_factor`,
// default 2) is its "params" (protocol 3), else --params (protocols 1 and 2, whose setting is
// checked at start, before the points are read). The points are read and converted once.
//
// The protocol's arguments, points file and loop: ../_shared/pointsight_protocol.hpp.
//
// Usage: pcl_voxel --points FILE --protocol 3 [--normals W] [--spacing S]   (views on stdin)
//        pcl_voxel --points FILE --params JSON --protocol 1|2 [--normals W] [--spacing S]
//        pcl_voxel --version
#include <pcl/filters/voxel_grid_occlusion_estimation.h>
#include <pcl/pcl_config.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "../_shared/pointsight_protocol.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

namespace protocol = pointsight_protocol;

// The voxel leaf of a setting (its params object): `leaf_size` world units, else
// `leaf_factor` (default 2) density spacings; throws when it cannot be had or is not > 0.
static double leaf_of(const std::string& params, double spacing) {
  double leaf = 0.0, factor = 2.0;
  if (!protocol::param_number(params, "leaf_size", leaf)) {
    protocol::param_number(params, "leaf_factor", factor);
    if (!(spacing > 0.0))
      throw std::runtime_error("no --spacing sent (protocol 1, or <= 8 points): give leaf_size");
    leaf = factor * spacing;
  }
  if (!(leaf > 0.0) || !std::isfinite(leaf)) throw std::runtime_error("leaf size must be > 0");
  return leaf;
}

int main(int argc, char** argv) {
  protocol::Args args = protocol::parse_args(argc, argv);
  if (args.version) {
    std::printf("PCL %s\n", PCL_VERSION_PRETTY);
    return 0;
  }
  const double spacing = args.spacing;
  try {
    if (args.points.empty()) throw std::runtime_error("no --points");
    // Protocols 1 and 2: the one setting fails here, before the points are read.
    if (args.protocol < 3) leaf_of(args.params, spacing);
    std::vector<double> xyz = protocol::read_xyz(args.points);
    size_t n = xyz.size() / 3;
    if (n == 0) throw std::runtime_error("the point cloud is empty");
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->resize(n);
    for (size_t i = 0; i < n; ++i)
      (*cloud)[i] = pcl::PointXYZ(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2]));
    protocol::serve([&](const std::string&, const double eye[3], const std::string& params) {
      const double leaf = leaf_of(params, spacing);
      const float lf = float(leaf);
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
      std::string extra = ",\"occluded_voxels\":[";
      std::sort(occluded.begin(), occluded.end());
      for (size_t k = 0; k < occluded.size(); ++k) {
        if (k) extra += ',';
        extra += "[" + std::to_string(std::get<0>(occluded[k])) + "," +
                 std::to_string(std::get<1>(occluded[k])) + "," +
                 std::to_string(std::get<2>(occluded[k])) + "]";
      }
      char leaf_field[48];
      std::snprintf(leaf_field, sizeof leaf_field, "],\"leaf\":%.9g", leaf);
      extra += leaf_field;
      protocol::send_visible(visible, extra, seconds);
    }, args.params);
  } catch (const std::exception& e) {
    protocol::send_error(e.what());
    std::fprintf(stderr, "pcl_voxel: %s\n", e.what());
    return 2;
  }
  return 0;
}

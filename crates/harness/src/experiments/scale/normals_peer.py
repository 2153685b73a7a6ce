"""A normal-estimation peer of the scale experiment: Open3D's or point-cloud-utils' 16-neighbour
normals of the points in a raw file, timed without the reading and writing.

Usage: normals_peer.py open3d|open3d-oriented|pcu POINTS NORMALS K

POINTS holds n x 3 little-endian float64 (x, y, z); NORMALS is written as n x 3 float32. The
last line on stdout is {"seconds": S}: the estimation alone (with open3d-oriented also
orient_normals_consistent_tangent_plane(K)).
"""

import json
import sys
import time

import numpy as np


def main():
    mode, points_path, normals_path, k = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    points = np.fromfile(points_path, dtype="<f8").reshape(-1, 3)
    if mode in ("open3d", "open3d-oriented"):
        import open3d as o3d

        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
        start = time.perf_counter()
        cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(k))
        if mode == "open3d-oriented":
            cloud.orient_normals_consistent_tangent_plane(k)
        seconds = time.perf_counter() - start
        normals = np.asarray(cloud.normals)
    elif mode == "pcu":
        import point_cloud_utils as pcu

        start = time.perf_counter()
        index, found = pcu.estimate_point_cloud_normals_knn(points, k)
        seconds = time.perf_counter() - start
        # The normals come in the order of `index` (not always the input's, and a point
        # without a normal is left out): put each at its point; a missing one stays zero.
        normals = np.zeros_like(points)
        normals[np.asarray(index, dtype=np.int64)] = found
    else:
        sys.exit(f"unknown mode {mode!r}")
    np.ascontiguousarray(normals, dtype="<f4").tofile(normals_path)
    print(json.dumps({"seconds": seconds}), flush=True)


if __name__ == "__main__":
    main()

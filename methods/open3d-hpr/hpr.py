"""Open3D's hidden point removal as a pointsight external method (protocol 3).

R = max|p - C| * 10**gamma, exactly as pointsight's `hpr` computes it, unless `radius` gives R.
One process serves every setting on its cloud: the cloud is loaded into an Open3D PointCloud
once; each request reads its setting (`gamma`, `radius`), calls
`PointCloud.hidden_point_removal(eye, R)` and reports its time alone (R included).
"""

import os
import sys
import time

import numpy as np
import open3d as o3d

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "_shared"))
import pointsight_protocol as protocol  # noqa: E402


def main():
    args, params = protocol.arguments()
    rows = protocol.read_rows(args.points)
    points = np.stack([rows["x"], rows["y"], rows["z"]], axis=1)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))

    def answer(request):
        setting = protocol.setting(request, params)
        gamma = float(setting.get("gamma", "3"))
        radius = float(setting["radius"]) if "radius" in setting else None
        eye = np.array(request["camera"]["eye"], dtype=np.float64)
        start = time.perf_counter()
        r = radius if radius is not None else float(np.max(np.linalg.norm(points - eye, axis=1)) * 10.0**gamma)
        _, indices = pcd.hidden_point_removal(eye.tolist(), r)
        seconds = time.perf_counter() - start
        return {"visible": sorted(int(i) for i in indices), "seconds": seconds}

    protocol.serve(answer)


if __name__ == "__main__":
    main()

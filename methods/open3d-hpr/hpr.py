"""Open3D's hidden point removal as a pointsight external method (protocol 1).

R = max|p - C| * 10**gamma, exactly as pointsight's `hpr` computes it, unless `radius` gives R.
The cloud is loaded into an Open3D PointCloud once; each view calls
`PointCloud.hidden_point_removal(eye, R)` and reports its time alone.
"""

import argparse
import json
import sys
import time

import numpy as np
import open3d as o3d


def read_points(path):
    with open(path, "rb") as f:
        n = None
        while True:
            line = f.readline().decode("ascii").strip()
            if line.startswith("element vertex"):
                n = int(line.split()[2])
            if line == "end_header":
                break
        return np.frombuffer(f.read(24 * n), dtype="<f8").reshape(n, 3).copy()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", required=True)
    ap.add_argument("--params", default="{}")
    ap.add_argument("--protocol", type=int, default=1)
    args = ap.parse_args()
    params = json.loads(args.params)
    gamma = float(params.get("gamma", "3"))
    radius = float(params["radius"]) if "radius" in params else None
    points = read_points(args.points)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    for line in sys.stdin:
        cam = json.loads(line)["camera"]
        eye = np.array(cam["eye"], dtype=np.float64)
        start = time.perf_counter()
        r = radius if radius is not None else float(np.max(np.linalg.norm(points - eye, axis=1)) * 10.0**gamma)
        _, indices = pcd.hidden_point_removal(eye.tolist(), r)
        seconds = time.perf_counter() - start
        print(json.dumps({"visible": sorted(int(i) for i in indices), "seconds": seconds}), flush=True)


if __name__ == "__main__":
    main()

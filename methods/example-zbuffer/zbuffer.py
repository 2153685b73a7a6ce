"""A point z-buffer in plain Python: the protocol-1 example of an external pointsight method.

Projects every point with the pinhole camera and keeps, per pixel of a z-buffer `scale` times
the camera's resolution, the nearest one; those points are visible. No splat, no tolerance:
the simplest image-space visibility, and a template for your own method (see ../README.md).
"""

import argparse
import json
import struct
import sys
import time


def read_points(path):
    """The binary little-endian PLY pointsight writes: `x y z` doubles."""
    with open(path, "rb") as f:
        n = None
        while True:
            line = f.readline().decode("ascii").strip()
            if line.startswith("element vertex"):
                n = int(line.split()[2])
            if line == "end_header":
                break
        data = f.read(24 * n)
    return [struct.unpack_from("<ddd", data, 24 * k) for k in range(n)]


def visible(points, cam, scale):
    m = cam["camera_to_world"]
    eye = [m[0][3], m[1][3], m[2][3]]
    right = [m[0][0], m[1][0], m[2][0]]
    down = [m[0][1], m[1][1], m[2][1]]
    fwd = [m[0][2], m[1][2], m[2][2]]
    fx, fy, cx, cy = cam["fx"] * scale, cam["fy"] * scale, cam["cx"] * scale, cam["cy"] * scale
    w, h = cam["width"] * scale, cam["height"] * scale
    nearest = {}
    for k, p in enumerate(points):
        v = (p[0] - eye[0], p[1] - eye[1], p[2] - eye[2])
        z = v[0] * fwd[0] + v[1] * fwd[1] + v[2] * fwd[2]
        if z <= 0:
            continue
        x = cx + fx * (v[0] * right[0] + v[1] * right[1] + v[2] * right[2]) / z
        y = cy + fy * (v[0] * down[0] + v[1] * down[1] + v[2] * down[2]) / z
        if 0 <= x < w and 0 <= y < h:
            pixel = (int(x), int(y))
            if pixel not in nearest or z < nearest[pixel][0]:
                nearest[pixel] = (z, k)
    return sorted(k for _, k in nearest.values())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", required=True)
    ap.add_argument("--params", default="{}")
    ap.add_argument("--protocol", type=int, default=1)
    args = ap.parse_args()
    params = json.loads(args.params)
    scale = int(params.get("scale", "1"))
    points = read_points(args.points)
    for line in sys.stdin:
        request = json.loads(line)
        cam = request["camera"]
        if cam["model"] != "pinhole":
            print(json.dumps({"error": f"pinhole cameras only, got {cam['model']}"}), flush=True)
            continue
        start = time.perf_counter()
        vis = visible(points, cam, scale)
        seconds = time.perf_counter() - start
        print(json.dumps({"visible": vis, "seconds": seconds}), flush=True)


if __name__ == "__main__":
    main()

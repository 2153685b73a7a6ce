"""A point z-buffer in plain Python: the protocol-1 example of an external pointsight method.

Projects every point with the pinhole camera and keeps, per pixel of a z-buffer `scale` times
the camera's resolution, the nearest one; those points are visible. No splat, no tolerance:
the simplest image-space visibility, and a template for your own method (see ../README.md).
"""

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "_shared"))
import pointsight_protocol as protocol  # noqa: E402


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
    args, params = protocol.arguments()
    scale = int(params.get("scale", "1"))
    points = protocol.read_xyz(args.points)

    def answer(request):
        cam = request["camera"]
        if cam["model"] != "pinhole":
            return {"error": f"pinhole cameras only, got {cam['model']}"}
        start = time.perf_counter()
        vis = visible(points, cam, scale)
        seconds = time.perf_counter() - start
        return {"visible": vis, "seconds": seconds}

    protocol.serve(answer)


if __name__ == "__main__":
    main()

"""A point z-buffer in plain Python: the protocol-3 example of an external pointsight method.

The same z-buffer as ../example-zbuffer (protocol 1): project every point with the pinhole
camera and keep, per pixel of a z-buffer `scale` times the camera's resolution, the nearest
one; those points are visible. Protocol 3 starts this program once per cloud and sends the
setting with every request, so the program splits its work in two (see ../README.md):

- per cloud, once, at start-up: read the points and lay them out as three columns;
- per request: read the setting (`protocol.setting`: the request's `params`, else the
  start-up `--params` of protocols 1 and 2, so the program speaks those too) and compute.

`protocol.serve` echoes each request's `id` in its answer. A program that builds something
per cloud (a BVH, a render window) times it and sends `protocol.built(seconds)` before its
first answer; this one only reads, so it sends none. Starting the interpreter and reading the
points are in pointsight's cold call (recorded apart), not in any request's `seconds`.
"""

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "_shared"))
import pointsight_protocol as protocol  # noqa: E402


def visible(columns, cam, scale):
    """The indices of the points nearest to the eye in their pixel, sorted."""
    xs, ys, zs = columns
    m = cam["camera_to_world"]
    ex, ey, ez = m[0][3], m[1][3], m[2][3]
    rx, ry, rz = m[0][0], m[1][0], m[2][0]
    dx, dy, dz = m[0][1], m[1][1], m[2][1]
    fx_, fy_, fz_ = m[0][2], m[1][2], m[2][2]
    fx, fy, cx, cy = cam["fx"] * scale, cam["fy"] * scale, cam["cx"] * scale, cam["cy"] * scale
    w, h = cam["width"] * scale, cam["height"] * scale
    nearest = {}
    for k, (px, py, pz) in enumerate(zip(xs, ys, zs)):
        vx, vy, vz = px - ex, py - ey, pz - ez
        z = vx * fx_ + vy * fy_ + vz * fz_
        if z <= 0:
            continue
        x = cx + fx * (vx * rx + vy * ry + vz * rz) / z
        y = cy + fy * (vx * dx + vy * dy + vz * dz) / z
        if 0 <= x < w and 0 <= y < h:
            pixel = (int(x), int(y))
            if pixel not in nearest or z < nearest[pixel][0]:
                nearest[pixel] = (z, k)
    return sorted(k for _, k in nearest.values())


def main():
    args, params = protocol.arguments()
    # Per cloud: the points, as columns (x, y, z).
    columns = tuple(zip(*protocol.read_xyz(args.points))) or ((), (), ())

    def answer(request):
        # Per request: the setting, then the view.
        setting = protocol.setting(request, params)
        scale = int(setting.get("scale", "1"))
        if scale < 1:
            raise ValueError(f"scale={scale}: must be at least 1")
        cam = request["camera"]
        if cam["model"] != "pinhole":
            raise ValueError(f"pinhole cameras only, got {cam['model']}")
        start = time.perf_counter()
        vis = visible(columns, cam, scale)
        seconds = time.perf_counter() - start
        return {"visible": vis, "seconds": seconds}

    protocol.serve(answer)


if __name__ == "__main__":
    main()

"""point-cloud-utils' RaySurfelIntersector as a pointsight external method (protocol 3).

Every point is an oriented disc (a surfel: a circle of `subdivs` triangles perpendicular to its
normal, the dataset's normals or pointsight's estimates, sent since protocol 2) of radius
`radius_factor` density spacings (the `--spacing` pointsight sends, the unit of its own
`raycast`'s radius), or `radius` world units. One process serves every setting on its cloud:
the points and normals are read once; Embree's BVH depends on the disc radius and `subdivs`,
so it is built the first time a request asks for that pair and kept for the next requests
(the last `KEEP` pairs), its build timed apart from the request's seconds and sent with that
answer as protocol 3's `built_seconds`. Per request one ray per pixel centre (x + 0.5, y + 0.5) of the pinhole
camera, at the view's resolution or `width` x `height`; a point is visible when some ray's
nearest hit is its disc. Against pointsight's `raycast`: its `primitive=disc` casts the same
discs (exact circles, doubles; `primitive` here only says so, so that the two pair); its
default spheres are another primitive. The disc here is a polygon of `subdivs` triangles
inscribed in the circle, and Embree intersects in floats.
"""

import os
import sys
import time

# numpy's OpenBLAS threads busy-wait between calls; the one product per view here (the rays'
# rotation) gains nothing from them (measured on bunny-69451, 16 views: 6.14 s of CPU with
# them, 4.23 s without, the same wall time).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import point_cloud_utils as pcu  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "_shared"))
import pointsight_protocol as protocol  # noqa: E402


def read_ply(path):
    """x y z and nx ny nz from pointsight's points file, as float32."""
    rows = protocol.read_rows(path)
    points = np.stack([rows["x"], rows["y"], rows["z"]], axis=1).astype(np.float32)
    if "nx" not in rows.dtype.names:
        raise SystemExit("pcu-raycast needs normals: declare protocol = 2 in method.toml")
    normals = np.stack([rows["nx"], rows["ny"], rows["nz"]], axis=1).astype(np.float32)
    return points, normals


def pixel_rays(cam, width, height):
    """Origins and unit directions (world) of one ray per pixel centre, row-major."""
    if cam["model"] != "pinhole":
        raise ValueError(f"pcu-raycast takes pinhole cameras, not {cam['model']}")
    # Another image size keeps the pose and the vertical field of view with square pixels, as
    # pointsight's `Camera::with_resolution`: focal lengths scale with the height, the
    # principal point proportionally (scaling fx by the width instead would stretch the pixels
    # of a 16:9 view at 4:3 and cast a quarter fewer rays across it).
    s = height / cam["height"]
    fx, fy = cam["fx"] * s, cam["fy"] * s
    cx, cy = cam["cx"] * width / cam["width"], cam["cy"] * s
    u, v = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    d = np.stack([(u - cx) / fx, (v - cy) / fy, np.ones_like(u)], axis=-1).reshape(-1, 3)
    m = np.array(cam["camera_to_world"], dtype=np.float64)
    d = d @ m[:3, :3].T
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(m[:3, 3], d.shape)
    return np.ascontiguousarray(o, dtype=np.float32), np.ascontiguousarray(d, dtype=np.float32)


# The BVHs kept, one per (radius, subdivs): the visibility experiment's grid has two radii;
# each BVH is most of the program's memory (memory_bytes_per_point counts one).
KEEP = 2


def main():
    args, params = protocol.arguments()
    points, normals = read_ply(args.points)
    bvhs = {}  # (radius, subdivs) -> intersector, least recently used first

    def intersector(radius, subdivs):
        """The BVH of discs of `radius` and `subdivs`, and its build seconds when built now."""
        key = (radius, subdivs)
        if key in bvhs:
            bvhs[key] = bvhs.pop(key)
            return bvhs[key], None
        while len(bvhs) >= KEEP:
            # Dropped before the next is built: at most KEEP in memory at once.
            del bvhs[next(iter(bvhs))]
        start = time.perf_counter()
        # The radius as a float32 array like the points: a scalar double is refused.
        radii = np.full(len(points), radius, dtype=np.float32)
        isect = pcu.RaySurfelIntersector(points, normals, r=radii, subdivs=subdivs)
        built = time.perf_counter() - start
        bvhs[key] = isect
        return isect, built

    def answer(request):
        setting = protocol.setting(request, params)
        if setting.get("primitive", "disc") != "disc":
            raise ValueError(f"pcu-raycast: primitive={setting['primitive']}: surfels are discs (disc only)")
        if "radius" in setting:
            radius = float(setting["radius"])
        elif args.spacing is None:
            raise ValueError("no --spacing sent (a cloud of at most 8 points): give radius")
        else:
            radius = float(setting.get("radius_factor", "1.5")) * args.spacing
        if not radius > 0:
            raise ValueError(f"pcu-raycast: disc radius {radius:g} is not positive")
        subdivs = int(setting.get("subdivs", "7"))
        cam = request["camera"]
        w = int(setting["width"]) if "width" in setting else cam["width"]
        h = int(setting["height"]) if "height" in setting else cam["height"]
        isect, built = intersector(radius, subdivs)
        o, d = pixel_rays(cam, w, h)
        t0 = time.perf_counter()
        # point-cloud-utils 0.3x returns (point ids, distances), whatever its docstring says.
        a, b = isect.intersect_rays(o, d)
        pid = np.asarray(a if np.issubdtype(np.asarray(a).dtype, np.integer) else b)
        visible = np.unique(pid[pid >= 0])
        seconds = time.perf_counter() - t0
        reply = {"visible": visible.tolist(), "seconds": seconds}
        if built is not None:
            reply["built_seconds"] = built
        return reply

    protocol.serve(answer)


if __name__ == "__main__":
    main()

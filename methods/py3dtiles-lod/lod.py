"""py3dtiles' 3D Tiles point-cloud tileset as a pointsight LOD method (protocol 3, LOD form).

Build (once per cloud, its own time reported): the cloud is written as PLY with its colours and
an extra attribute `index`, the point's original index (3D Tiles reorders and quantises the
points), and converted by `py3dtiles convert --extra-fields index` into an octree tileset
(`tileset.json` + `.pnts` tiles); every tile's original indices are read back from its batch
table. Per request (one process serves every setting on its cloud: the setting is the
request's) the tileset is cut by 3D Tiles' own rule (3D Tiles 1.0 specification, "Geometric
error" and "Refinement"): a tile is refined when its screen-space error
SSE = geometricError · height / (2 · d · tan(fov_y / 2)) exceeds `sse_px` pixels (Cesium's
maximumScreenSpaceError, default 16), d the distance from the eye to the tile's bounding sphere;
`REPLACE` tiles draw their children instead of themselves, `ADD` tiles draw both. Each selected
point is a splat of radius max(R, geometricError / 2), Cesium's point attenuation (a point
covers its tile's geometric error), R the full-detail splat radius pointsight sends.

Deviations: no frustum culling (pointsight's LOD scoring renders what is selected; a viewer
would also drop tiles outside the view, which changes the count, not the image); the bounding
sphere is the box's circumscribed sphere.
"""

import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "_shared"))
import pointsight_protocol as protocol  # noqa: E402


def mat(t):
    """A 3D Tiles transform (16 numbers, column-major) as a 4 x 4 matrix."""
    return np.array(t, dtype=np.float64).reshape(4, 4).T if t else np.eye(4)


class Tile:
    def __init__(self, node, parent_world, parent_refine, root):
        self.world = parent_world @ mat(node.get("transform"))
        box = np.array(node["boundingVolume"]["box"], dtype=np.float64)
        self.centre = (self.world @ np.append(box[:3], 1.0))[:3]
        axes = box[3:].reshape(3, 3) @ self.world[:3, :3].T
        self.radius = float(np.linalg.norm(axes, axis=1).sum())
        self.error = float(node["geometricError"])
        self.refine = node.get("refine", parent_refine)
        self.indices = np.zeros(0, dtype=np.int64)
        content = node.get("content")
        if content:
            from py3dtiles.tileset.content import read_binary_tile_content

            pnts = read_binary_tile_content(Path(root) / content["uri"])
            self.indices = np.asarray(pnts.body.batch_table.get_binary_property("index"), dtype=np.int64)
        self.children = [Tile(c, self.world, self.refine, root) for c in node.get("children", [])]

    def count(self):
        return 1 + sum(c.count() for c in self.children)


def cut(tile, eye, k, sse_px, base_radius, out):
    """3D Tiles' traversal: refine while the screen-space error exceeds sse_px."""
    d = max(float(np.linalg.norm(tile.centre - eye)) - tile.radius, 1e-9)
    refine = bool(tile.children) and tile.error * k / d > sse_px
    if not refine or tile.refine == "ADD":
        out.append((tile.indices, max(base_radius, tile.error / 2)))
    if refine:
        for c in tile.children:
            cut(c, eye, k, sse_px, base_radius, out)


def main():
    args, params = protocol.arguments()
    if not args.lod:
        protocol.send({"error": "py3dtiles-lod speaks the LOD form only (kind = lod)"})
        return
    rows = protocol.read_rows(args.points)
    n = len(rows)
    base_radius = args.radius or 0.0
    start = time.perf_counter()
    work = tempfile.mkdtemp(prefix="py3dtiles-lod-")
    # The tileset lives until the end of input (the harness closes it when the cell is done).
    try:
        dt = np.dtype([("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("red", "u1"), ("green", "u1"),
                       ("blue", "u1"), ("index", "<u4")])
        out = np.zeros(n, dt)
        for c in "xyz":
            out[c] = rows[c]
        for c in ("red", "green", "blue"):
            out[c] = rows[c] if c in rows.dtype.names else 200
        out["index"] = np.arange(n, dtype=np.uint32)
        src = os.path.join(work, "in.ply")
        with open(src, "wb") as f:
            f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty double x\n"
                     "property double y\nproperty double z\nproperty uchar red\nproperty uchar green\n"
                     "property uchar blue\nproperty uint index\nend_header\n" % n).encode())
            f.write(out.tobytes())
        tiles = os.path.join(work, "tiles")
        py3dtiles = os.path.join(os.path.dirname(sys.executable), "py3dtiles")
        subprocess.run([py3dtiles, "convert", src, "--out", tiles, "--extra-fields", "index",
                        "--jobs", "1", "--disable-processpool"], check=True,
                       stdout=sys.stderr, stderr=sys.stderr)
        with open(os.path.join(tiles, "tileset.json")) as f:
            root = Tile(json.load(f)["root"], np.eye(4), "REPLACE", tiles)
        seconds = time.perf_counter() - start
        nbytes = sum(p.stat().st_size for p in Path(tiles).rglob("*") if p.is_file())
        protocol.built(seconds, nodes=root.count(), bytes=nbytes)

        def answer(req):
            cam = req["camera"]
            sse_px = float(protocol.setting(req, params).get("sse_px", "16"))
            t0 = time.perf_counter()
            eye = np.array(cam["eye"], dtype=np.float64)
            if cam["model"] == "pinhole":
                k = cam["height"] / (2.0 * math.tan(math.radians(cam["fov_y_deg"]) / 2.0))
            else:
                raise ValueError(f"py3dtiles-lod takes pinhole cameras, not {cam['model']}")
            picked = []
            cut(root, eye, k, sse_px, base_radius, picked)
            if picked:
                idx = np.concatenate([p[0] for p in picked])
                rad = np.concatenate([np.full(len(p[0]), p[1]) for p in picked])
                # A point in several selected tiles (the root's preview) is drawn once, at its
                # smallest radius.
                order = np.lexsort((rad, idx))
                idx, rad = idx[order], rad[order]
                first = np.ones(len(idx), dtype=bool)
                first[1:] = idx[1:] != idx[:-1]
                idx, rad = idx[first], rad[first]
            else:
                idx, rad = np.zeros(0, np.int64), np.zeros(0)
            seconds = time.perf_counter() - t0
            return {"visible": idx.tolist(), "radius": rad.tolist(), "seconds": seconds}

        protocol.serve(answer)
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()

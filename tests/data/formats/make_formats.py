"""Writes the small files the readers' tests read, with other tools than ours.

Run once, by hand, in a virtual environment with `pip install laspy lazrs pye57 numpy`
(laspy 2.7, lazrs 0.7, pye57 0.4 were used); the outputs are committed beside this script
(`python make_formats.py normals` writes the normals' files alone, with laspy and lazrs):

- tiny.las, tiny.laz: laspy (LAS 1.4, point format 3: RGB, intensity, classification), the
  LAZ through lazrs; georeferenced coordinates (offset 500000, 4000000, 100; scale 0.001).
- normals_pdal.las/.laz, normals_spaced.las/.laz, normals_nxyz.las/.laz: laspy, point format
  0 with the NORMALS below as extra bytes under each naming convention: `NormalX`... as f32
  (PDAL's dimensions, CloudCompare's export), `normal x`... as f64 after an f64 `Deviation`
  field, `nx`... as i16 scaled by 1e-4.
- tiny_normals.ply, tiny_normals.pcd: by hand, ASCII, the POINTS (local, as the PCD files)
  with the NORMALS as `nx ny nz` and `normal_x normal_y normal_z`.
- tiny.e57: pye57 (libE57Format), two scans of the same points with different poses.
- tiny_ascii.pcd, tiny_binary.pcd, tiny_compressed.pcd: by hand (PCL's documented layout);
  the compressed one in LZF literal runs (valid LZF that compresses nothing).

The points: POINTS below; their colours COLORS, intensities INTENSITY, classes CLASSES.
"""

import struct

import laspy
import numpy as np
try:
    import pye57
except ImportError:  # `normals` alone needs no pye57
    pye57 = None

POINTS = np.array(
    [
        [500000.125, 4000000.250, 100.500],
        [500001.000, 4000000.000, 101.000],
        [500000.000, 4000001.500, 99.750],
        [500002.375, 4000002.000, 100.000],
        [500000.500, 4000000.500, 102.125],
    ]
)
COLORS = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [10, 20, 30], [200, 100, 50]], dtype=np.uint16)
INTENSITY = np.array([100, 200, 300, 400, 65535], dtype=np.uint16)
CLASSES = np.array([2, 2, 6, 1, 6], dtype=np.uint8)
NORMALS = np.array(
    [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.6, 0.8, 0.0], [0.0, -0.6, 0.8], [-0.48, 0.6, 0.64]]
)


def las(path):
    header = laspy.LasHeader(point_format=3, version="1.4")
    header.offsets = np.array([500000.0, 4000000.0, 100.0])
    header.scales = np.array([0.001, 0.001, 0.001])
    data = laspy.LasData(header)
    data.x, data.y, data.z = POINTS[:, 0], POINTS[:, 1], POINTS[:, 2]
    data.red, data.green, data.blue = (COLORS * 257).T
    data.intensity = INTENSITY
    data.classification = CLASSES
    data.write(path)


def e57(path):
    local = POINTS - POINTS.mean(axis=0)
    with pye57.E57(path, mode="w") as f:
        # Scan 0: identity pose; scan 1: rotated 90 degrees about z and moved by (10, 0, 0).
        f.write_scan_raw(
            {"cartesianX": local[:, 0], "cartesianY": local[:, 1], "cartesianZ": local[:, 2]},
            name="scan-a",
            rotation=np.array([1.0, 0.0, 0.0, 0.0]),
            translation=np.array([0.0, 0.0, 0.0]),
        )
        c = np.sqrt(0.5)
        f.write_scan_raw(
            {"cartesianX": local[:, 0], "cartesianY": local[:, 1], "cartesianZ": local[:, 2]},
            name="scan-b",
            rotation=np.array([c, 0.0, 0.0, c]),
            translation=np.array([10.0, 0.0, 0.0]),
        )


def pcd_header(data, n):
    return (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb intensity\n"
        "SIZE 4 4 4 4 4\nTYPE F F F F F\nCOUNT 1 1 1 1 1\n"
        f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n"
    ).encode()


def local_points():
    return (POINTS - np.array([500000.0, 4000000.0, 100.0])).astype(np.float32)


def packed_rgb(c):
    return struct.unpack("<f", struct.pack("<I", (int(c[0]) << 16) | (int(c[1]) << 8) | int(c[2])))[0]


def pcds():
    pts = local_points()
    n = len(pts)
    with open("tiny_ascii.pcd", "wb") as f:
        f.write(pcd_header("ascii", n))
        for p, c, i in zip(pts, COLORS, INTENSITY):
            rgb = (int(c[0]) << 16) | (int(c[1]) << 8) | int(c[2])
            rgb_float = struct.unpack("<f", struct.pack("<I", rgb))[0]
            f.write(f"{float(p[0])!r} {float(p[1])!r} {float(p[2])!r} {rgb_float!r} {float(i) / 65535.0!r}\n".encode())
    rows = [struct.pack("<fffff", *p, packed_rgb(c), i / 65535.0) for p, c, i in zip(pts, COLORS, INTENSITY)]
    with open("tiny_binary.pcd", "wb") as f:
        f.write(pcd_header("binary", n))
        f.write(b"".join(rows))
    # binary_compressed: fields column by column, then LZF.
    columns = b"".join(
        b"".join(row[4 * k : 4 * k + 4] for row in rows) for k in range(5)
    )
    lzf = b""
    for start in range(0, len(columns), 32):
        run = columns[start : start + 32]
        lzf += bytes([len(run) - 1]) + run
    with open("tiny_compressed.pcd", "wb") as f:
        f.write(pcd_header("binary_compressed", n))
        f.write(struct.pack("<II", len(lzf), len(columns)))
        f.write(lzf)


def las_normals(path, names, dtype, scale=None, before=None):
    header = laspy.LasHeader(point_format=0, version="1.4")
    header.offsets = np.array([500000.0, 4000000.0, 100.0])
    header.scales = np.array([0.001, 0.001, 0.001])
    if before is not None:
        header.add_extra_dims([laspy.ExtraBytesParams(name=before, type=np.float64)])
    scales = None if scale is None else np.array([scale])
    header.add_extra_dims(
        [laspy.ExtraBytesParams(name=n, type=dtype, scales=scales, offsets=None if scale is None else np.array([0.0])) for n in names]
    )
    data = laspy.LasData(header)
    data.x, data.y, data.z = POINTS[:, 0], POINTS[:, 1], POINTS[:, 2]
    if before is not None:
        data[before] = np.arange(5) * 0.25
    for k, n in enumerate(names):
        data[n] = NORMALS[:, k]
    data.write(path)


def normals():
    for ext in ["las", "laz"]:
        las_normals(f"normals_pdal.{ext}", ["NormalX", "NormalY", "NormalZ"], np.float32)
        las_normals(
            f"normals_spaced.{ext}", ["normal x", "normal y", "normal z"], np.float64, before="Deviation"
        )
        las_normals(f"normals_nxyz.{ext}", ["nx", "ny", "nz"], np.int16, scale=1e-4)
    local = local_points()
    with open("tiny_normals.ply", "w", newline="\n") as f:
        f.write(
            "ply\nformat ascii 1.0\ncomment NORMALS of make_formats.py\nelement vertex 5\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\nend_header\n"
        )
        for p, n in zip(local, NORMALS):
            f.write(" ".join(repr(float(v)) for v in [*p, *n]) + "\n")
    with open("tiny_normals.pcd", "w", newline="\n") as f:
        f.write(
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
            "FIELDS x y z normal_x normal_y normal_z\nSIZE 4 4 4 4 4 4\nTYPE F F F F F F\n"
            "COUNT 1 1 1 1 1 1\nWIDTH 5\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 5\nDATA ascii\n"
        )
        for p, n in zip(local, NORMALS):
            f.write(" ".join(repr(float(v)) for v in [*p, *n]) + "\n")


if __name__ == "__main__":
    import sys

    if sys.argv[1:] == ["normals"]:
        normals()
    else:
        las("tiny.las")
        las("tiny.laz")
        e57("tiny.e57")
        pcds()
        normals()

"""Writes the example scene of docs/own-data.md ("Your own data"): a floor with two boxes, as a mesh
(scene.off) and as a noisy scan of it (scan.ply, ASCII, written by this script, not by
pointsight): 6,000 points uniform on the surface, 2 mm Gaussian noise along the normals and
60 outliers up to 0.3 m off the surface. Python's standard library only; seeded.

    python3 make_scene.py
"""

import random

random.seed(2026)

# Axis-aligned boxes (min, max); the floor is a flat box of zero height.
BOXES = [
    ((-2.0, -2.0, 0.0), (2.0, 2.0, 0.0)),   # floor
    ((-0.6, -0.4, 0.0), (0.2, 0.4, 0.9)),   # a cupboard
    ((0.6, 0.3, 0.0), (1.2, 0.9, 0.4)),     # a crate
]


def faces(lo, hi):
    """The box's faces as quads (4 corners, outward normal); a flat box gives its top only."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    top = ([(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)], (0, 0, 1))
    if z1 == z0:
        return [top]
    return [
        top,
        ([(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)], (0, -1, 0)),
        ([(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)], (1, 0, 0)),
        ([(x1, y1, z0), (x0, y1, z0), (x0, y1, z1), (x1, y1, z1)], (0, 1, 0)),
        ([(x0, y1, z0), (x0, y0, z0), (x0, y0, z1), (x0, y1, z1)], (-1, 0, 0)),
    ]


quads = [q for lo, hi in BOXES for q in faces(lo, hi)]


def area(q):
    c = q[0]
    a = [c[1][i] - c[0][i] for i in range(3)]
    b = [c[3][i] - c[0][i] for i in range(3)]
    cross = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    return sum(v * v for v in cross) ** 0.5


with open("scene.off", "w") as f:
    f.write("OFF\n# a floor with two boxes (make_scene.py)\n")
    f.write(f"{4 * len(quads)} {2 * len(quads)} 0\n")
    for corners, _ in quads:
        for c in corners:
            f.write(f"{c[0]} {c[1]} {c[2]}\n")
    for k in range(len(quads)):
        b = 4 * k
        f.write(f"3 {b} {b + 1} {b + 2}\n3 {b} {b + 2} {b + 3}\n")

areas = [area(q) for q in quads]
points = []
for i in range(6000):
    corners, n = random.choices(quads, weights=areas)[0]
    u, v = random.random(), random.random()
    c = corners
    p = [c[0][k] + u * (c[1][k] - c[0][k]) + v * (c[3][k] - c[0][k]) for k in range(3)]
    off = random.uniform(0.05, 0.3) if i % 100 == 0 else random.gauss(0.0, 0.002)
    points.append([p[k] + off * n[k] for k in range(3)])

with open("scan.ply", "w") as f:
    f.write("ply\nformat ascii 1.0\ncomment a noisy scan (make_scene.py)\n")
    f.write(f"element vertex {len(points)}\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
    for p in points:
        f.write(f"{p[0]:.5f} {p[1]:.5f} {p[2]:.5f}\n")

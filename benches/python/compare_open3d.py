"""Open3D's hidden_point_removal against pointsight's exact HPR, in one process, on the same
array, eye and radius; each repeated, with the spread.

    pointsight export --dataset dragon-871414 --out /tmp/dragon.ply
    pointsight views --dataset dragon-871414 --format jsonl --out /tmp/dragon.jsonl
    python benches/python/compare_open3d.py /tmp/dragon.ply /tmp/dragon.jsonl --gammas 3 4

R = max|p - eye| * 10**gamma (Katz's parameterisation, Open3D takes R absolute). Prints, per
gamma: each side's median, minimum and maximum seconds over --repeats runs, the ratio of the
medians (Open3D / pointsight) with the range of per-run ratios, the visible counts and the
Jaccard index of the two sets. Needs numpy, open3d (the open3d-cpu wheel) and pointsight.
"""

import argparse
import json
import statistics
import time

import numpy as np
import open3d as o3d

import pointsight as ps


def timed(f, repeats):
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t)
    return out, times


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("points", help="a point file pointsight reads (PLY from `pointsight export`)")
    ap.add_argument("views", help="a views file (JSON lines); the eye of --view is used")
    ap.add_argument("--view", type=int, default=0)
    ap.add_argument("--gammas", type=float, nargs="+", default=[3.0, 4.0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()

    points = ps.read_cloud(args.points)["positions"]
    eye = np.array(json.loads(open(args.views).read().splitlines()[args.view])["eye"])
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    print(f"points={len(points)} view={args.view} eye={eye.tolist()} repeats={args.repeats} open3d={o3d.__version__}")
    for gamma in args.gammas:
        radius = float(np.max(np.linalg.norm(points - eye, axis=1)) * 10.0**gamma)
        (_, theirs), t_o3d = timed(lambda: pcd.hidden_point_removal(eye.tolist(), radius), args.repeats)
        ours, t_ps = timed(lambda: ps.hidden_point_removal(points, eye, radius), args.repeats)
        theirs = np.sort(np.asarray(theirs))
        s = ps.score(ours, theirs, len(points))
        ratios = [a / b for a, b in zip(t_o3d, t_ps)]
        print(
            f"gamma={gamma:g} radius={radius:.6g} "
            f"open3d_median={statistics.median(t_o3d):.4f} open3d_min={min(t_o3d):.4f} open3d_max={max(t_o3d):.4f} "
            f"pointsight_median={statistics.median(t_ps):.4f} pointsight_min={min(t_ps):.4f} pointsight_max={max(t_ps):.4f} "
            f"ratio={statistics.median(t_o3d) / statistics.median(t_ps):.2f} "
            f"ratio_range={min(ratios):.2f}..{max(ratios):.2f} "
            f"visible_open3d={len(theirs)} visible_pointsight={len(ours)} jaccard={s['jaccard']:.6f}"
        )


if __name__ == "__main__":
    main()

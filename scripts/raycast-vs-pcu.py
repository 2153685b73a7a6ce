"""raycast's cast against point-cloud-utils' RaySurfelIntersector on the same rays, alternated
in one run.

Usage (from anywhere; the peer from `just peers`):
    .venv/bin/python scripts/raycast-vs-pcu.py [--pairs 5] [--points 871414 --seed 871414
        --width 1920 --height 1080] [--builds 0] [--baseline EXE]

The caster's side is the example `peer_cast` of the raycast crate (built in release, run as a
child that answers one cast per line): it samples the dragon, takes view 0 and the radius of 1.5
density spacings, builds its hierarchy and writes the points, normals and rays (unit
directions, one per pixel centre) as f32 to a temporary folder. This script builds the peer's
Embree BVH on those points and normals (discs of the same radius, `subdivs` 7 as the external
method `pcu-raycast`), then runs `--pairs` rounds of: raycast spheres, raycast discs,
point-cloud-utils discs, the order rotated each round. Each cast is timed by wall clock and by
process CPU time (all threads; the caster's from /proc, the peer's by `time.process_time` in
this process, where Embree runs), with the load average beside it. It prints every cast, then
medians, min-max and rays/s by both clocks, the ratios, and how often the two disc casts agree
on the point a pixel sees. `--baseline EXE` adds the same casts by a `peer_cast` built from
another revision (say main's raycast crate), alternated with the rest, and checks that its rays
and per-pixel hits are byte for byte this revision's.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

try:
    import numpy as np
    import point_cloud_utils as pcu
except ImportError as e:
    raise SystemExit(f"{e}: install the peer with `just peers` and run this with .venv/bin/python")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NONE = 0xFFFFFFFF


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("--points", type=int, default=871_414)
    ap.add_argument("--seed", type=int, default=871_414)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--subdivs", type=int, default=7)
    ap.add_argument("--builds", type=int, default=0, help="extra timed builds of each")
    ap.add_argument("--no-peer", action="store_true",
                    help="leave point-cloud-utils out (its peak is about 1.6 kB a point)")
    ap.add_argument("--baseline", metavar="EXE",
                    help="a peer_cast built from another revision, alternated with this one")
    args = ap.parse_args()

    subprocess.run(
        ["cargo", "build", "-q", "--release", "-p", "raycast", "--example", "peer_cast"],
        cwd=ROOT,
        check=True,
    )
    exe = os.path.join(ROOT, "target", "release", "examples", "peer_cast")
    with tempfile.TemporaryDirectory(prefix="raycast-vs-pcu-") as tmp:
        def start(exe, folder):
            child = subprocess.Popen(
                [exe, folder, str(args.points), str(args.seed), str(args.width), str(args.height)],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                text=True,
            )
            ready = child.stdout.readline().split()
            if not ready or ready[0] != "ready":
                raise SystemExit(f"{exe} did not start (exit {child.wait()})")
            return child, int(ready[1]), (float(ready[2]), float(ready[3]))

        def asker(child):
            def ask(command):
                child.stdin.write(command + "\n")
                child.stdin.flush()
                line = child.stdout.readline()
                if not line:
                    raise SystemExit(f"peer_cast ended on {command!r} (exit {child.wait()})")
                return [float(x) for x in line.split()]
            return ask

        child, n_rays, built = start(exe, tmp)
        ask = asker(child)
        builds = {"raycast": [built], "pcu": []}
        base = None
        if args.baseline:
            base_dir = os.path.join(tmp, "baseline")
            base, _, built = start(args.baseline, base_dir)
            ask_base = asker(base)
            builds["baseline"] = [built]

        def load(name):
            return np.fromfile(os.path.join(tmp, name), dtype="<f4").reshape(-1, 3)

        points, normals = load("points.f32"), load("normals.f32")
        origins, dirs = load("origins.f32"), load("dirs.f32")
        radius = float(open(os.path.join(tmp, "radius.txt")).read())
        radii = np.full(len(points), radius, dtype=np.float32)

        def pcu_build():
            t, c = time.perf_counter(), time.process_time()
            isect = pcu.RaySurfelIntersector(points, normals, r=radii, subdivs=args.subdivs)
            return isect, (time.perf_counter() - t, time.process_time() - c)

        if not args.no_peer:
            isect, b = pcu_build()
            builds["pcu"].append(b)
        for _ in range(args.builds):
            builds["raycast"].append(tuple(ask("build")))
            if base:
                builds["baseline"].append(tuple(ask_base("build")))
            if not args.no_peer:
                del isect
                isect, b = pcu_build()
                builds["pcu"].append(b)

        pcu_pixels = None

        def pcu_cast():
            nonlocal pcu_pixels
            t, c = time.perf_counter(), time.process_time()
            a, b = isect.intersect_rays(origins, dirs)
            pid = np.asarray(a if np.issubdtype(np.asarray(a).dtype, np.integer) else b)
            visible = np.unique(pid[pid >= 0])
            wall, cpu = time.perf_counter() - t, time.process_time() - c
            if pcu_pixels is None:
                pcu_pixels = pid
            return wall, cpu, len(visible)

        runs = {
            "raycast sphere": lambda: ask("sphere"),
            "raycast disc": lambda: ask("disc"),
        }
        if not args.no_peer:
            runs["pcu disc"] = pcu_cast
        if base:
            runs["baseline sphere"] = lambda: ask_base("sphere")
            runs["baseline disc"] = lambda: ask_base("disc")
        names = list(runs)
        times = {k: [] for k in names}
        loads = []
        print(f"{args.points} points, {args.width}x{args.height} = {n_rays} rays, "
              f"radius {radius:.6g}; cpu count {os.cpu_count()}")
        for r in range(args.pairs):
            order = names[r % len(names):] + names[:r % len(names)]
            for name in order:
                load1 = os.getloadavg()[0]
                wall, cpu, visible = runs[name]()
                loads.append(load1)
                times[name].append((wall, cpu))
                print(f"round {r} {name:15s} wall {wall:.4f} s cpu {cpu:.4f} s "
                      f"visible {int(visible)} load {load1:.1f}", flush=True)
        child.stdin.close()
        child.wait()
        if base:
            base.stdin.close()
            base.wait()
            for name in ("origins.f32", "dirs.f32", "pixels-sphere.u32", "pixels-disc.u32"):
                same = open(os.path.join(tmp, name), "rb").read() == open(
                    os.path.join(base_dir, name), "rb").read()
                print(f"baseline's {name} {'identical' if same else 'DIFFERENT'}")
        ours = np.fromfile(os.path.join(tmp, "pixels-disc.u32"), dtype="<u4").astype(np.int64)
        ours[ours == NONE] = -1

    if not args.no_peer:
        theirs = np.asarray(pcu_pixels, dtype=np.int64)
        hit_any = (ours >= 0) | (theirs >= 0)
        same = (ours == theirs) & hit_any
        print(f"\ndisc pixels hit by either: {hit_any.sum()}, same point: {same.sum()} "
              f"({same.sum() / max(hit_any.sum(), 1):.4f}); hit by ours only "
              f"{((ours >= 0) & (theirs < 0)).sum()}, by pcu only {((ours < 0) & (theirs >= 0)).sum()}")
    print(f"load average during the casts: {min(loads):.1f} to {max(loads):.1f} "
          f"(median {statistics.median(loads):.1f}) on {os.cpu_count()} cores")

    def summary(pairs, k):
        xs = [p[k] for p in pairs]
        return statistics.median(xs), min(xs), max(xs)

    for clock, k in (("wall", 0), ("process CPU", 1)):
        print(f"\n{clock}: median [min, max] seconds, rays/s at the median")
        med = {}
        for name in names:
            m, lo, hi = summary(times[name], k)
            med[name] = m
            print(f"  {name:15s} {m:.4f} [{lo:.4f}, {hi:.4f}]  {n_rays / m / 1e6:.1f} M rays/s")
        for name in [x for x in names if x in ("raycast sphere", "raycast disc") and "pcu disc" in med]:
            ratios = [p[k] / o[k] for o, p in zip(times[name], times["pcu disc"])]
            print(f"  pcu / {name}: {med['pcu disc'] / med[name]:.2f}x at the medians, "
                  f"per round {min(ratios):.2f}x to {max(ratios):.2f}x")
        if base:
            for prim in ("sphere", "disc"):
                ratios = [b[k] / o[k] for o, b in zip(times[f"raycast {prim}"], times[f"baseline {prim}"])]
                print(f"  baseline / raycast {prim}: {med[f'baseline {prim}'] / med[f'raycast {prim}']:.2f}x "
                      f"at the medians, per round {min(ratios):.2f}x to {max(ratios):.2f}x")
        for name in [b for b in builds if builds[b]]:
            m, lo, hi = summary(builds[name], k)
            print(f"  build {name:9s} {m:.4f} [{lo:.4f}, {hi:.4f}] ({len(builds[name])})")


if __name__ == "__main__":
    sys.exit(main())

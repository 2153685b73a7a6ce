"""Trains the learned visibility network (`model.MyNet`) on the labels of our ground truth
(`crates/harness/examples/neuralvis_data.rs` writes them) and exports the weights file the Rust
method reads, with its training record beside it.

One step: one training cloud (drawn by the step's seed), a random subset of its points (the
paper's `takes`: 2048 up to `--max-points`), a random rotation of points and eyes together (the
labels do not change), the points normalised into [-0.8, 0.8]^3 by their bounding box (the
paper's `normalize(bbmin, bbmax, scale=0.8)`), their octree, the U-Net's features, and the
cross entropy of the head over `--views` of the cloud's 16 views (outliers, label 255, left
out). AdamW with gradient clipping at 1 (the paper's), the rate dropped tenfold at
`--milestones` (70 % and 90 % of the steps; the paper's 15 and 30 of 50 epochs are 30 % and
60 % of a far longer run).

Reproducible: `--seed` fixes the initial weights and every draw (step k draws from
`default_rng([seed, k])`); a checkpoint is written every `--checkpoint-minutes` and on SIGTERM
or SIGINT, and a run started again with the same `--out` resumes at the step after it.
The validation F1 (threshold 0.5, mean over the validation clouds' views) is measured every
`--val-every` steps beside HPR's on the same views.
"""

import argparse
import json
import math
import os
import platform
import signal
import subprocess
import sys
import time

import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import model as M  # noqa: E402
import nvw  # noqa: E402


def normalise(points, scale=0.8):
    """The paper's bounding-box normalisation into [-scale, scale]^3, in float64 (the Rust side
    computes the same expression), then float32."""
    lo, hi = points.min(0), points.max(0)
    centre = (lo + hi) * 0.5
    box = (hi - lo).max() + 1e-6
    return ((points - centre) * ((2.0 * scale) / box)).astype(np.float32)


def directions(points, eyes):
    """Unit directions from each eye to each point, float64 (rows: point-major, view-minor)."""
    d = points[:, None, :] - eyes[None, :, :]
    d = d / np.linalg.norm(d, axis=2, keepdims=True)
    return d.reshape(-1, 3)


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def load_data(folder):
    manifest = json.load(open(os.path.join(folder, "manifest.json")))
    clouds = {"train": [], "validation": []}
    for c in manifest["clouds"]:
        name = c["entry"]["name"]
        item = {
            "name": name,
            "mesh": c["mesh"],
            "points": np.load(os.path.join(folder, f"{name}.points.npy")),
            "eyes": np.load(os.path.join(folder, f"{name}.eyes.npy")),
            "labels": np.load(os.path.join(folder, f"{name}.labels.npy")),
        }
        hpr = os.path.join(folder, f"{name}.hpr.npy")
        if os.path.exists(hpr):
            item["hpr"] = np.load(hpr)
        clouds[c["split"]].append(item)
    return manifest, clouds


def forward(net, cfg, points64, eyes64):
    """Logits (points * views, 2) of `net` on one cloud seen from `eyes64`."""
    p32 = torch.from_numpy(normalise(points64, cfg.scale))
    octree = M.build_octree(p32, cfg)
    q = torch.cat([p32, torch.zeros(len(p32), 1)], dim=1)
    feat = net.features(octree, q)
    enc = M.encode(torch.from_numpy(directions(points64, eyes64)), cfg.multires).float()
    v = len(eyes64)
    feat = feat.unsqueeze(1).expand(-1, v, -1).reshape(-1, cfg.feature_channels)
    return net.head(feat, enc)


def f1_per_view(pred, truth):
    """F1 of each column (views) of boolean (points, views) arrays; 1 when both are empty."""
    tp = (pred & truth).sum(0)
    denom = pred.sum(0) + truth.sum(0)
    return np.where(denom > 0, 2 * tp / np.maximum(denom, 1), 1.0)


def validate(net, cfg, clouds, thresholds=(0.3, 0.4, 0.5, 0.6, 0.7)):
    net.eval()
    out = {"f1": {str(t): [] for t in thresholds}, "hpr_f1": [], "per_mesh": {}}
    with torch.no_grad():
        for c in clouds:
            logits = forward(net, cfg, c["points"], c["eyes"])
            prob = torch.softmax(logits, 1)[:, 1].numpy().reshape(len(c["points"]), -1)
            truth = c["labels"] == 1
            for t in thresholds:
                out["f1"][str(t)].extend(f1_per_view(prob >= t, truth).tolist())
            f = f1_per_view(prob >= 0.5, truth)
            h = f1_per_view(c["hpr"] == 1, truth) if "hpr" in c else None
            out["per_mesh"][c["mesh"]] = {
                "f1": float(f.mean()),
                "hpr_f1": float(h.mean()) if h is not None else None,
            }
            if h is not None:
                out["hpr_f1"].extend(h.tolist())
    net.train()
    summary = {
        "f1": float(np.mean(out["f1"]["0.5"])),
        "f1_by_threshold": {t: float(np.mean(v)) for t, v in out["f1"].items()},
        "hpr_f1": float(np.mean(out["hpr_f1"])) if out["hpr_f1"] else None,
        "views": len(out["f1"]["0.5"]),
        "per_mesh": out["per_mesh"],
    }
    return summary


def git_revision():
    try:
        here = os.path.dirname(os.path.abspath(__file__))
        return subprocess.run(["git", "-C", here, "rev-parse", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except Exception:  # noqa: BLE001
        return "unknown"


def lr_at(step, steps, base, milestones):
    return base * (0.1 ** sum(step >= m * steps for m in milestones))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="the label generator's output folder")
    ap.add_argument("--out", required=True, help="run folder: checkpoints, log, exported files")
    ap.add_argument("--seed", type=int, default=66)
    ap.add_argument("--config", choices=["cpu", "paper", "tiny"], default="cpu")
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--milestones", type=lambda t: [float(x) for x in t.split(",")],
                    default=[0.7, 0.9],
                    help="fractions of the steps where the rate drops tenfold (the paper: 0.3,0.6 "
                         "of 50 epochs; later here, where the steps are few)")
    ap.add_argument("--weight-decay", type=float, default=1e-5)
    ap.add_argument("--max-points", type=int, default=12000)
    ap.add_argument("--views", type=int, default=8, help="views of 16 per step")
    ap.add_argument("--val-every", type=int, default=250)
    ap.add_argument("--checkpoint-minutes", type=float, default=5.0)
    ap.add_argument("--threads", type=int, default=1,
                    help="torch threads (1: on a shared machine two threads wait on each other)")
    ap.add_argument("--slow", action="store_true", help="ocnn's own kernels (no fast gather)")
    ap.add_argument("--export", action="store_true",
                    help="export the weights as they are now, finished or not (the record says "
                         "which step); no training step is run")
    ap.add_argument("--stop-after-minutes", type=float, default=None,
                    help="stop (with a checkpoint) after this much wall time in this sitting")
    args = ap.parse_args()

    torch.set_num_threads(args.threads)
    cfg = getattr(M.Config, args.config)()
    os.makedirs(args.out, exist_ok=True)
    ckpt_path = os.path.join(args.out, "checkpoint.pt")
    log_path = os.path.join(args.out, "log.jsonl")
    manifest, clouds = load_data(args.data)
    if not clouds["train"]:
        sys.exit(f"{args.data} has no training clouds")

    torch.manual_seed(args.seed)
    net = M.MyNet(cfg, fast=not args.slow)
    opt = torch.optim.AdamW(net.parameters(), lr=args.lr, weight_decay=args.weight_decay)
    state = {"step": 0, "wall_seconds": 0.0, "losses": [], "validations": [], "loads": [],
             "sittings": 0}
    if os.path.exists(ckpt_path):
        ck = torch.load(ckpt_path, weights_only=False)
        if ck["args"]["seed"] != args.seed or ck["args"]["config"] != args.config:
            sys.exit(f"{ckpt_path} is of another run (seed/config differ); use another --out")
        net.load_state_dict(ck["model"])
        opt.load_state_dict(ck["optimizer"])
        state = ck["state"]
        print(f"resuming at step {state['step']} ({state['wall_seconds']:.0f} s so far)",
              flush=True)
    else:
        err = M.check_fast(cfg, torch.from_numpy(normalise(clouds["train"][0]["points"][:4000])))
        print(f"fast kernels agree with ocnn's to {err:.2e}", flush=True)
    state["sittings"] += 1

    stop = {"now": False}

    def on_signal(signum, _frame):
        stop["now"] = True
        print(f"signal {signum}: stopping after this step", flush=True)

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)

    def save():
        tmp = ckpt_path + ".part"
        torch.save({"model": net.state_dict(), "optimizer": opt.state_dict(), "state": state,
                    "args": vars(args)}, tmp)
        os.replace(tmp, ckpt_path)

    sitting_start = time.time()
    last_save = time.time()
    tick = time.time()
    net.train()
    while state["step"] < args.steps and not stop["now"] and not args.export:
        step = state["step"]
        rng = np.random.default_rng([args.seed, step])
        for g in opt.param_groups:
            g["lr"] = lr_at(step, args.steps, args.lr, args.milestones)
        c = clouds["train"][rng.integers(len(clouds["train"]))]
        n = len(c["points"])
        take = min(n, int(rng.integers(2048, max(args.max_points, 2049))))
        idx = rng.permutation(n)[:take]
        views = rng.permutation(c["eyes"].shape[0])[:args.views]
        rot = random_rotation(rng)
        pts = c["points"][idx] @ rot.T
        eyes = c["eyes"][views] @ rot.T
        labels = torch.from_numpy(c["labels"][idx][:, views].reshape(-1).astype(np.int64))
        logits = forward(net, cfg, pts, eyes)
        loss = torch.nn.functional.cross_entropy(logits, labels, ignore_index=255)
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(net.parameters(), 1.0)
        opt.step()
        now = time.time()
        state["wall_seconds"] += now - tick
        tick = now
        state["step"] = step + 1
        state["losses"].append([step, loss.item(), take])
        if step % 10 == 0:
            state["loads"].append([step, os.getloadavg()[0]])
            print(f"step {step} loss {float(loss):.4f} points {take} "
                  f"wall {state['wall_seconds']:.0f} s load {os.getloadavg()[0]:.1f}", flush=True)
        if state["step"] % args.val_every == 0 or state["step"] == args.steps:
            v = validate(net, cfg, clouds["validation"])
            v["step"] = state["step"]
            v["wall_seconds"] = state["wall_seconds"]
            state["validations"].append(v)
            with open(log_path, "a") as f:
                f.write(json.dumps(v) + "\n")
            print(f"validation at step {state['step']}: F1 {v['f1']:.4f} "
                  f"(HPR {v['hpr_f1']}) by threshold {v['f1_by_threshold']}", flush=True)
            tick = time.time()  # validation time is not training time
        if time.time() - last_save > 60 * args.checkpoint_minutes:
            save()
            last_save = time.time()
        if args.stop_after_minutes and time.time() - sitting_start > 60 * args.stop_after_minutes:
            print("time limit of this sitting reached", flush=True)
            break
    save()
    if state["step"] < args.steps and not args.export:
        print(f"stopped at step {state['step']} of {args.steps}; run again to resume", flush=True)
        return
    if not state["validations"] or state["validations"][-1]["step"] != state["step"]:
        v = validate(net, cfg, clouds["validation"])
        v["step"], v["wall_seconds"] = state["step"], state["wall_seconds"]
        state["validations"].append(v)
        save()

    net.eval()
    record = {
        "paper": "Wang, Tian, Chen and Wang, Neural Visibility of Point Sets, SIGGRAPH Asia 2025 "
                 "(arXiv 2509.24150); our training of their design",
        "seed": args.seed,
        "revision": git_revision(),
        "args": vars(args),
        "steps": state["step"],
        "steps_planned": args.steps,
        "sittings": state["sittings"],
        "wall_seconds": state["wall_seconds"],
        "machine": {"cpu": platform.processor() or platform.machine(),
                    "cores": os.cpu_count(), "threads": args.threads,
                    "load_mean": float(np.mean([l for _, l in state["loads"]]))
                    if state["loads"] else None},
        "versions": {"torch": torch.__version__, "ocnn": __import__("ocnn").__version__,
                     "python": platform.python_version()},
        "data": {"seed": manifest["seed"], "revision": manifest["meta"]["git_revision"],
                 "meshes": manifest["meshes"],
                 "train_clouds": len(clouds["train"]),
                 "validation_clouds": len(clouds["validation"])},
        "loss_curve": [[s, float(np.mean([l for _, l, _ in state["losses"][max(0, s - 50):s]]))]
                       for s in range(50, state["step"] + 1, 50)],
        "losses": state["losses"],
        "validation": state["validations"],
        "final_validation": state["validations"][-1] if state["validations"] else None,
    }
    name = f"neuralvis-{args.config}-d{cfg.depth}"
    size = nvw.write(os.path.join(args.out, f"{name}.nvw"), cfg.to_json(),
                     nvw.state_tensors(net.state_dict()), {k: record[k] for k in
                     ("paper", "seed", "revision", "steps", "wall_seconds")})
    with open(os.path.join(args.out, f"{name}.training.json"), "w") as f:
        json.dump(record, f, indent=1)
    print(f"wrote {name}.nvw ({size / 1e6:.1f} MB) and its record; "
          f"{state['wall_seconds'] / 60:.1f} min of training", flush=True)


if __name__ == "__main__":
    main()

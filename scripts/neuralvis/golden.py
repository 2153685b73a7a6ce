"""The goldens the Rust inference is tested against (`crates/neuralvis/tests/goldens.rs`), made
with PyTorch and ocnn's own kernels (not the training's fast gather):

- `forward`: a small network of the same structure (`Config.tiny`), seeded random weights and
  batch-norm statistics, on a synthetic cloud seen from three eyes: its weights file, and per
  point the U-Net feature and P(visible) per eye;
- `committed`: the committed weights on a synthetic scene (a ball in front of a square) from
  two eyes: P(visible) per point and eye.

Usage: golden.py forward OUT_DIR | golden.py committed WEIGHTS OUT_JSON
"""

import json
import os
import sys

import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import model as M  # noqa: E402
import nvw  # noqa: E402
import train as T  # noqa: E402


def run(net, cfg, points, eyes):
    net.eval()
    p32 = torch.from_numpy(T.normalise(points, cfg.scale))
    octree = M.build_octree(p32, cfg)
    q = torch.cat([p32, torch.zeros(len(p32), 1)], dim=1)
    with torch.no_grad():
        feat = net.features(octree, q)
        enc = M.encode(torch.from_numpy(T.directions(points, eyes)), cfg.multires).float()
        v = len(eyes)
        f = feat.unsqueeze(1).expand(-1, v, -1).reshape(-1, cfg.feature_channels)
        prob = torch.softmax(net.head(f, enc), 1)[:, 1].reshape(len(points), v)
    return feat.numpy(), prob.numpy()


def load(path):
    config, tensors, record = nvw.read(path)
    cfg = M.Config(**config)
    net = M.MyNet(cfg, fast=False)
    missing, unexpected = net.load_state_dict(
        {k: torch.from_numpy(np.array(v)) for k, v in tensors.items()}, strict=False)
    assert not unexpected and all(k.endswith("num_batches_tracked") for k in missing), missing
    return net, cfg


def curve_cloud(n, rng):
    """A trefoil tube and a wavy sheet: non-convex, self-occluding."""
    t = rng.uniform(0, 2 * np.pi, n // 2)
    a = rng.uniform(0, 2 * np.pi, n // 2)
    c = np.stack([np.sin(t) + 2 * np.sin(2 * t), np.cos(t) - 2 * np.cos(2 * t), -np.sin(3 * t)], 1)
    tube = c + 0.4 * np.stack([np.cos(a), np.sin(a), np.cos(a) * np.sin(a)], 1)
    u, w = rng.uniform(-3, 3, (2, n - n // 2))
    sheet = np.stack([u, w, -2.5 + 0.3 * np.sin(2 * u) * np.cos(w)], 1)
    return np.concatenate([tube, sheet]) * 1.7 + np.array([10.0, -4.0, 2.5])


def ball_and_square(n_ball, n_square, rng):
    z = rng.uniform(-1, 1, n_ball)
    phi = rng.uniform(0, 2 * np.pi, n_ball)
    r = np.sqrt(1 - z * z)
    ball = np.stack([r * np.cos(phi), r * np.sin(phi), z + 2.0], 1)
    x, y = rng.uniform(-3, 3, (2, n_square))
    return np.concatenate([ball, np.stack([x, y, np.zeros(n_square)], 1)])


def forward(out_dir):
    torch.manual_seed(7)
    cfg = M.Config.tiny()
    net = M.MyNet(cfg, fast=False)
    g = torch.Generator().manual_seed(8)
    with torch.no_grad():
        for name, t in net.state_dict().items():
            if name.endswith("running_mean"):
                t.copy_(0.2 * torch.randn(t.shape, generator=g))
            elif name.endswith("running_var"):
                t.copy_(0.5 + torch.rand(t.shape, generator=g))
            elif name.endswith("bn.weight"):
                t.copy_(0.5 + torch.rand(t.shape, generator=g))
            elif name.endswith("bn.bias") or name.endswith("linear.bias"):
                t.copy_(0.1 * torch.randn(t.shape, generator=g))
        # A head that separates: the random logits' layer scaled up so that the
        # probabilities spread over (0, 1) rather than sit near 0.5.
        net.VisNet.mlp[-1].linear.weight.mul_(40.0)
    rng = np.random.default_rng(9)
    points = curve_cloud(300, rng)
    eyes = np.array([[30.0, 5.0, 9.0], [-12.0, -30.0, -4.0], [10.0, -4.0, 40.0]])
    feat, prob = run(net, cfg, points, eyes)
    size = nvw.write(os.path.join(out_dir, "tiny.nvw"), cfg.to_json(),
                     nvw.state_tensors(net.state_dict()),
                     {"purpose": "forward-pass golden: seeded random weights"})
    golden = {"points": points.tolist(), "eyes": eyes.tolist(),
              "features": feat.astype(float).tolist(), "probabilities": prob.astype(float).tolist(),
              "made_by": f"torch {torch.__version__}, ocnn {__import__('ocnn').__version__}"}
    with open(os.path.join(out_dir, "tiny.golden.json"), "w") as f:
        json.dump(golden, f)
    print(f"tiny.nvw {size} bytes, {len(points)} points; probabilities in "
          f"[{prob.min():.3f}, {prob.max():.3f}]")


def committed(weights, out_json):
    net, cfg = load(weights)
    rng = np.random.default_rng(11)
    points = ball_and_square(600, 900, rng)
    eyes = np.array([[0.3, -0.2, 8.0], [6.0, 1.0, 1.5]])
    _, prob = run(net, cfg, points, eyes)
    golden = {"points": points.tolist(), "eyes": eyes.tolist(),
              "probabilities": prob.astype(float).tolist(),
              "weights_sha256": open(weights, "rb").read()[-32:].hex(),
              "made_by": f"torch {torch.__version__}, ocnn {__import__('ocnn').__version__}"}
    with open(out_json, "w") as f:
        json.dump(golden, f)
    print(f"{len(points)} points; visible at 0.5: {(prob >= 0.5).sum(0).tolist()}")


if __name__ == "__main__":
    torch.set_num_threads(1)
    if sys.argv[1] == "forward":
        forward(sys.argv[2])
    elif sys.argv[1] == "committed":
        committed(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)

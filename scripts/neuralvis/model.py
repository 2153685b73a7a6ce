"""The network of "Neural Visibility of Point Sets" (Wang, Tian, Chen and Wang, SIGGRAPH Asia
2025, arXiv 2509.24150) on `ocnn`: an octree U-Net gives each point a view-independent feature
(63 channels), and a shared MLP classifies the feature times a positional encoding of the view
direction as hidden (class 0) or visible (class 1).

The module tree and parameter names are those of the authors' code (`MyNet` with `UNet` and
`VisNet`; ResNet blocks of two 3x3x3 octree convolutions with batch norm), so that a state dict
of theirs and ours have the same keys; the configuration (channels, blocks, octree depth) is a
`Config`, whose `paper()` is theirs. The Rust inference (`crates/neuralvis`) reads the same
tensors from the exported weights file.

`fast=True` swaps ocnn's octree convolution kernels for a padded gather and one matrix product
per layer (same parameters, same arithmetic up to summation order: `check_fast` asserts the
outputs agree); ocnn's CPU kernels spend most of their time in boolean indexing.
"""

from dataclasses import asdict, dataclass, field
from typing import Dict, List

import ocnn
import torch
from ocnn.octree import Octree

#: Channels of the point feature (the paper's header width, = the encoding's width).
FEATURE_CHANNELS = 63


@dataclass
class Config:
    """The architecture: what the weights file's header records."""

    depth: int = 8
    full_depth: int = 2
    scale: float = 0.8
    feature: str = "LP"
    in_channels: int = 6
    encoder_channels: List[int] = field(default_factory=lambda: [32, 32, 64, 128, 256])
    decoder_channels: List[int] = field(default_factory=lambda: [256, 256, 128, 96, 96])
    encoder_blocks: List[int] = field(default_factory=lambda: [2, 3, 4, 6])
    decoder_blocks: List[int] = field(default_factory=lambda: [2, 2, 2, 2])
    feature_channels: int = FEATURE_CHANNELS
    multires: int = 10
    head_channels: List[int] = field(default_factory=lambda: [128, 64])
    bn_eps: float = 1e-5
    interp: str = "linear"
    nempty: bool = True

    @staticmethod
    def paper():
        """The authors' configuration (their `UNet.config_network`, `vis_shapenet.yaml`)."""
        return Config()

    @staticmethod
    def cpu():
        """Ours for 2 CPU cores and a 20 MB weights file: half the channels, fewer blocks."""
        return Config(
            encoder_channels=[16, 16, 32, 64, 128],
            decoder_channels=[128, 128, 64, 48, 48],
            encoder_blocks=[1, 1, 2, 2],
            decoder_blocks=[1, 1, 1, 1],
        )

    @staticmethod
    def tiny():
        """A small instance of the same structure, for the forward-pass golden."""
        return Config(
            depth=6,
            encoder_channels=[8, 8, 12, 16],
            decoder_channels=[16, 16, 12, 12],
            encoder_blocks=[1, 2, 1],
            decoder_blocks=[1, 1, 2],
            head_channels=[16, 8],
        )

    def to_json(self):
        return asdict(self)


class FastConv(ocnn.nn.OctreeConv):
    """ocnn's `OctreeConv` (same `weights`), computed by a padded gather and one product."""

    def forward(self, data, octree, depth):
        neigh = octree.get_neigh(depth, self.kernel, self.stride, self.nempty)
        n = data.shape[0]
        pad = torch.cat([data, data.new_zeros(1, data.shape[1])])
        idx = torch.where(neigh >= 0, neigh, torch.full_like(neigh, n))
        col = pad[idx]
        out = col.flatten(1) @ self.weights.flatten(0, 1)
        if self.use_bias:
            out = out + self.bias
        return out


class FastDeconv(ocnn.nn.OctreeDeconv):
    """ocnn's stride-2 `OctreeDeconv` on non-empty nodes (same `weights`), as a gather."""

    def forward(self, data, octree, depth):
        assert self.stride == 2 and self.nempty and self.kernel == "222"
        neigh = octree.get_neigh(depth + 1, "222", 2, True)  # (N_d, 8) children or -1
        col = data @ self.weights.flatten(0, 1).t()  # (N_d, 8 * C_out)
        col = col.reshape(-1, self.out_channels)
        flat = torch.arange(neigh.numel(), device=data.device).view_as(neigh)
        valid = neigh >= 0
        inv = torch.empty(int(octree.nnum_nempty[depth + 1]), dtype=torch.long, device=data.device)
        inv[neigh[valid]] = flat[valid]
        out = col[inv]
        if self.use_bias:
            out = out + self.bias
        return out


def _conv(fast):
    return FastConv if fast else ocnn.nn.OctreeConv


def _deconv(fast):
    return FastDeconv if fast else ocnn.nn.OctreeDeconv


class ConvBnRelu(torch.nn.Module):
    def __init__(self, cin, cout, kernel=(3,), stride=1, nempty=True, fast=False, relu=True):
        super().__init__()
        self.conv = _conv(fast)(cin, cout, list(kernel), stride, nempty)
        self.bn = torch.nn.BatchNorm1d(cout)
        self.relu = relu

    def forward(self, data, octree, depth):
        out = self.bn(self.conv(data, octree, depth))
        return torch.relu(out) if self.relu else out


class DeconvBnRelu(torch.nn.Module):
    def __init__(self, cin, cout, nempty=True, fast=False):
        super().__init__()
        self.deconv = _deconv(fast)(cin, cout, [2], 2, nempty)
        self.bn = torch.nn.BatchNorm1d(cout)

    def forward(self, data, octree, depth):
        return torch.relu(self.bn(self.deconv(data, octree, depth)))


class Conv1x1Bn(torch.nn.Module):
    def __init__(self, cin, cout, relu=False):
        super().__init__()
        self.conv = ocnn.modules.Conv1x1(cin, cout, use_bias=False)
        self.bn = torch.nn.BatchNorm1d(cout)
        self.relu = relu

    def forward(self, data):
        out = self.bn(self.conv(data))
        return torch.relu(out) if self.relu else out


class ResBlock(torch.nn.Module):
    """Two 3x3x3 octree convolutions with batch norm, ReLU between and after the sum; a 1x1
    convolution with batch norm on the shortcut when the widths differ."""

    fast = False

    def __init__(self, cin, cout, stride=1, bottleneck=1, nempty=True):
        super().__init__()
        assert stride == 1 and bottleneck == 1
        self.cin, self.cout = cin, cout
        self.conv3x3a = ConvBnRelu(cin, cout, nempty=nempty, fast=self.fast)
        self.conv3x3b = ConvBnRelu(cout, cout, nempty=nempty, fast=self.fast, relu=False)
        if cin != cout:
            self.conv1x1 = Conv1x1Bn(cin, cout)

    def forward(self, data, octree, depth):
        out = self.conv3x3b(self.conv3x3a(data, octree, depth), octree, depth)
        shortcut = self.conv1x1(data) if self.cin != self.cout else data
        return torch.relu(out + shortcut)


class FastResBlock(ResBlock):
    fast = True


class UNet(torch.nn.Module):
    def __init__(self, cfg: Config, fast=False):
        super().__init__()
        enc, dec = cfg.encoder_channels, cfg.decoder_channels
        self.stages = len(cfg.encoder_blocks)
        assert len(enc) == self.stages + 1 and len(dec) == self.stages + 1
        assert len(cfg.decoder_blocks) == self.stages and dec[0] == enc[-1]
        block = FastResBlock if fast else ResBlock
        self.conv1 = ConvBnRelu(cfg.in_channels, enc[0], nempty=cfg.nempty, fast=fast)
        self.downsample = torch.nn.ModuleList([
            ConvBnRelu(enc[i], enc[i + 1], kernel=(2,), stride=2, nempty=cfg.nempty, fast=fast)
            for i in range(self.stages)])
        self.encoder = torch.nn.ModuleList([
            ocnn.modules.OctreeResBlocks(enc[i + 1], enc[i + 1], cfg.encoder_blocks[i], 1,
                                         cfg.nempty, block)
            for i in range(self.stages)])
        skip = [dec[i + 1] + enc[-i - 2] for i in range(self.stages)]
        self.upsample = torch.nn.ModuleList([
            DeconvBnRelu(dec[i], dec[i + 1], nempty=cfg.nempty, fast=fast)
            for i in range(self.stages)])
        self.decoder = torch.nn.ModuleList([
            ocnn.modules.OctreeResBlocks(skip[i], dec[i + 1], cfg.decoder_blocks[i], 1,
                                         cfg.nempty, block)
            for i in range(self.stages)])
        self.header = ocnn.modules.Conv1x1(dec[-1], cfg.feature_channels, use_bias=True)
        self.octree_interp = ocnn.nn.OctreeInterp(cfg.interp, cfg.nempty)

    def forward(self, data, octree: Octree, depth: int, query_pts):
        convd: Dict[int, torch.Tensor] = {depth: self.conv1(data, octree, depth)}
        for i in range(self.stages):
            d = depth - i
            convd[d - 1] = self.encoder[i](self.downsample[i](convd[d], octree, d), octree, d - 1)
        deconv = convd[depth - self.stages]
        for i in range(self.stages):
            d = depth - self.stages + i
            deconv = self.upsample[i](deconv, octree, d)
            deconv = torch.cat([convd[d + 1], deconv], dim=1)
            deconv = self.decoder[i](deconv, octree, d + 1)
        return self.octree_interp(self.header(deconv), octree, depth, query_pts)


class VisNet(torch.nn.Module):
    def __init__(self, cfg: Config):
        super().__init__()
        h = cfg.head_channels
        layers = [Conv1x1Bn(cfg.feature_channels, h[0], relu=True)]
        layers += [Conv1x1Bn(h[i], h[i + 1], relu=True) for i in range(len(h) - 1)]
        layers += [ocnn.modules.Conv1x1(h[-1], 2, use_bias=True)]
        self.mlp = torch.nn.Sequential(*layers)

    def forward(self, x):
        return self.mlp(x)


class MyNet(torch.nn.Module):
    def __init__(self, cfg: Config, fast=False):
        super().__init__()
        self.cfg = cfg
        self.UNet = UNet(cfg, fast)
        self.VisNet = VisNet(cfg)

    def features(self, octree, query_pts):
        return self.UNet(input_feature(octree), octree, octree.depth, query_pts)

    def head(self, features, encoded_dirs):
        """Logits (rows, 2) of `features` (rows, 63) times the encoded directions."""
        return self.VisNet(features * encoded_dirs)


def input_feature(octree: Octree):
    """The paper's 'LP' signal: each finest node's mean point, local (frac - 0.5) and global
    (in [-1, 1])."""
    d = octree.depth
    pts = octree.points[d]
    return torch.cat([pts.frac() - 0.5, pts * 2 ** (1 - d) - 1.0], dim=1)


def encode(dirs, multires=10):
    """NeRF's positional encoding of unit directions (rows, 3) -> (rows, 3 + 6 * multires):
    the input, then sin and cos of 2^k times it for k = 0 .. multires - 1, blocks of 3."""
    out = [dirs]
    for k in range(multires):
        out += [torch.sin(dirs * 2.0 ** k), torch.cos(dirs * 2.0 ** k)]
    return torch.cat(out, dim=1)


def build_octree(points_f32, cfg: Config):
    """The octree of normalised points (torch float32, in [-scale, scale]^3)."""
    octree = Octree(cfg.depth, cfg.full_depth)
    octree.build_octree(ocnn.octree.Points(points_f32))
    octree.construct_all_neigh()
    return octree


def check_fast(cfg: Config, points_f32, seed=0):
    """The fast kernels give ocnn's outputs (eval mode, the same weights)."""
    torch.manual_seed(seed)
    slow, fast = MyNet(cfg, fast=False), MyNet(cfg, fast=True)
    fast.load_state_dict(slow.state_dict())
    slow.eval(), fast.eval()
    octree = build_octree(points_f32, cfg)
    q = torch.cat([points_f32, torch.zeros(len(points_f32), 1)], dim=1)
    with torch.no_grad():
        a = slow.features(octree, q.clone())
        b = fast.features(octree, q.clone())
    err = (a - b).abs().max().item()
    assert err < 1e-4, f"fast kernels differ from ocnn's by {err}"
    return err

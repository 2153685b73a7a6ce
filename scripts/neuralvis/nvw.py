"""The weights file the Rust inference reads (`crates/neuralvis/src/weights.rs` is the
reader and the format's definition):

    magic      8 bytes   b"PSNVIS\\x00\\x01"
    version    u32 LE    1
    header     u32 LE    length H of the header
    payload    u64 LE    length P of the payload
    header     H bytes   JSON: {"config": {...}, "tensors": [{"name", "shape", "offset"}],
                                "record": {...}}; offsets in bytes into the payload
    payload    P bytes   the tensors, float32 little-endian, C order
    checksum   32 bytes  SHA-256 of every byte before it

The tensors are the model's state dict as PyTorch names it (ocnn's layouts: an octree
convolution's `weights` is (kernel volume, in, out), a deconvolution's (8, out, in)); batch
norms keep their running statistics and the reader folds them.
"""

import hashlib
import json
import os
import struct

import numpy as np

MAGIC = b"PSNVIS\x00\x01"
VERSION = 1


def state_tensors(state_dict):
    """The float tensors of a state dict (batch norms' `num_batches_tracked` left out)."""
    out = {}
    for name, t in state_dict.items():
        if name.endswith("num_batches_tracked"):
            continue
        out[name] = t.detach().cpu().numpy().astype("<f4")
    return out


def encode(config: dict, tensors: dict, record: dict) -> bytes:
    table, chunks, offset = [], [], 0
    for name in sorted(tensors):
        a = np.ascontiguousarray(tensors[name], dtype="<f4")
        table.append({"name": name, "shape": list(a.shape), "offset": offset})
        chunks.append(a.tobytes())
        offset += a.nbytes
    header = json.dumps({"config": config, "tensors": table, "record": record},
                        sort_keys=True).encode()
    payload = b"".join(chunks)
    body = MAGIC + struct.pack("<IIQ", VERSION, len(header), len(payload)) + header + payload
    return body + hashlib.sha256(body).digest()


def write(path, config: dict, tensors: dict, record: dict):
    """Writes the file whole (a temporary file renamed)."""
    data = encode(config, tensors, record)
    tmp = f"{path}.part"
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)
    return len(data)


def read(path):
    """(config, tensors, record) of a file `write` made, checked."""
    data = open(path, "rb").read()
    assert data[:8] == MAGIC, f"{path}: not a weights file"
    version, h, p = struct.unpack("<IIQ", data[8:24])
    assert version == VERSION
    assert hashlib.sha256(data[:-32]).digest() == data[-32:], f"{path}: checksum"
    header = json.loads(data[24:24 + h])
    payload = data[24 + h:24 + h + p]
    tensors = {}
    for t in header["tensors"]:
        n = int(np.prod(t["shape"])) if t["shape"] else 1
        tensors[t["name"]] = np.frombuffer(payload, "<f4", n, t["offset"]).reshape(t["shape"])
    return header["config"], tensors, header["record"]

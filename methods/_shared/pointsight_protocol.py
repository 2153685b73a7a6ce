"""The external-method protocol of pointsight (../README.md), for methods written in Python.

What every method program shares: its arguments (`arguments`), the points file pointsight
writes (binary little-endian PLY: `read_rows` as a numpy structured array, `read_xyz` with the
standard library alone), the setting a request asks for (`setting`: the request's `params`
with protocol 3 and the LOD form, else the start-up `--params`), and the JSON-lines loop
(`send`, `built`, `serve`: one request line in, one answer line out, flushed, echoing the
request's `id` when it has one). The same program serves protocols 1, 2 and 3 when it reads
its setting with `setting` (per request) and answers through `serve`. A method imports it with

    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "_shared"))
    import pointsight_protocol as protocol

Nothing here knows a method: the answers are the method's.
"""

import argparse
import json
import struct
import sys

# PLY property types pointsight writes, as numpy type strings and struct sizes.
_NUMPY = {"double": "<f8", "float": "<f4", "uchar": "u1"}


def arguments(extra=None):
    """The arguments pointsight appends (`--points FILE --protocol P`, with `--params JSON` in
    protocols 1 and 2, protocol 2's and 3's `--normals W --spacing S`, the LOD form's `--lod
    --radius R`) as (args, params): `params` the `--params` object (strings by key; keys not
    given are absent; `{}` when none is passed, as in protocol 3). `extra(parser)` may add a
    method's own flags; `--points` is then optional (the method checks it)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", required=extra is None)
    ap.add_argument("--params", default="{}")
    ap.add_argument("--protocol", type=int, default=1)
    ap.add_argument("--normals", default=None)
    ap.add_argument("--spacing", type=float, default=None)
    ap.add_argument("--radius", type=float, default=None)
    ap.add_argument("--lod", action="store_true")
    if extra is not None:
        extra(ap)
    args = ap.parse_args()
    return args, json.loads(args.params)


def _header(f):
    """The vertex count and (name, type) of each vertex property; `f` left at the body."""
    n, props, in_vertex = None, [], False
    while True:
        raw = f.readline()
        if not raw:
            raise ValueError("the PLY header has no end_header")
        words = raw.decode("ascii").split()
        if not words:
            continue
        if words[0] == "format" and words[1] != "binary_little_endian":
            raise ValueError(f"the PLY is {words[1]}, not binary_little_endian")
        if words[0] == "element":
            in_vertex = words[1] == "vertex"
            if in_vertex:
                n = int(words[2])
        elif words[0] == "property" and in_vertex:
            props.append((words[2], words[1]))
        elif words[0] == "end_header":
            if n is None:
                raise ValueError("the PLY has no vertex element")
            return n, props


def read_rows(path):
    """Every vertex of pointsight's points file as a numpy structured array: `x y z` doubles,
    and with protocol 2 `nx ny nz` floats, `red green blue` uchars and `u v` floats when sent."""
    import numpy as np

    with open(path, "rb") as f:
        n, props = _header(f)
        dtype = np.dtype([(name, _NUMPY[t]) for name, t in props])
        return np.frombuffer(f.read(n * dtype.itemsize), dtype=dtype, count=n)


def read_xyz(path):
    """The points' `x y z` as a list of tuples, with the standard library alone (the other
    properties skipped)."""
    sizes = {"double": 8, "float": 4, "uchar": 1}
    with open(path, "rb") as f:
        n, props = _header(f)
        if [name for name, _ in props[:3]] != ["x", "y", "z"] or any(t != "double" for _, t in props[:3]):
            raise ValueError("the vertex element does not start with double x y z")
        stride = sum(sizes[t] for _, t in props)
        data = f.read(stride * n)
    return [struct.unpack_from("<ddd", data, stride * k) for k in range(n)]


def setting(request, params):
    """The setting `request` asks for, strings by key (keys not given are absent: the method's
    own default applies): the request's `params` (protocol 3, where one process serves every
    setting, and the LOD form), else `params`, the start-up `--params` object of `arguments`
    (protocols 1 and 2: one process per setting). Whatever depends on the setting is read from
    this per request."""
    given = request.get("params")
    return params if given is None else given


def send(answer):
    """One line of JSON on standard output, flushed (pointsight waits for it)."""
    print(json.dumps(answer), flush=True)


def built(seconds, **extra):
    """The optional first line: the method's own set-up time (and the LOD form's `nodes`,
    `bytes`)."""
    send({"built": True, "seconds": seconds, **extra})


def serve(answer, errors=(ValueError, KeyError)):
    """The loop: for each request line (`{"view": K, "camera": CAMERA}`; protocol 3's and the
    LOD form's with `params`; protocol 3's with `"id": N` first) sends `answer(request)` (a
    dict: `visible`, `seconds`, ...); a request that raises one of `errors` is answered
    `{"error": message}` and the loop goes on. A request's `id` is the first key of its reply,
    an error reply's too (a line that is not JSON has none to echo). End of input ends it."""
    for line in sys.stdin:
        request = None
        try:
            request = json.loads(line)
            reply = answer(request)
        except errors as e:
            reply = {"error": str(e)}
        if isinstance(request, dict) and "id" in request:
            reply = {"id": request["id"], **{k: v for k, v in reply.items() if k != "id"}}
        send(reply)

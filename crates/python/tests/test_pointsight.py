"""The Python package against the command line (same indices), the readers, every error case,
threads, and Open3D where it is installed. Run by `just test` (so by CI)."""

import json
import os
import shutil
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest

import pointsight as ps

ROOT = Path(__file__).resolve().parents[3]


def cli() -> str:
    """The pointsight binary: $POINTSIGHT_BIN, else the workspace's debug or release build."""
    if os.environ.get("POINTSIGHT_BIN"):
        return os.environ["POINTSIGHT_BIN"]
    for profile in ("debug", "release"):
        p = ROOT / "target" / profile / "pointsight"
        if p.exists():
            return str(p)
    pytest.skip("no pointsight binary: run `cargo build -p harness` first")


def run(*args, cwd=None):
    out = subprocess.run([cli(), *args], capture_output=True, text=True, cwd=cwd or ROOT)
    assert out.returncode == 0, out.stderr
    return out.stdout


def read_indices(path):
    text = Path(path).read_text()
    return np.array([int(x) for x in text.split()], dtype=np.int64)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """sphere-plane-24000 as the command line exports it, and its 16 views."""
    d = tmp_path_factory.mktemp("ds")
    run("export", "--dataset", "sphere-plane-24000", "--out", str(d / "points.ply"))
    run("views", "--dataset", "sphere-plane-24000", "--format", "jsonl", "--out", str(d / "views.jsonl"))
    points = ps.read_cloud(d / "points.ply")["positions"]
    views = (d / "views.jsonl").read_text().splitlines()
    return d, points, views


@pytest.mark.parametrize(
    "method,sets,call",
    [
        ("hpr", [], lambda p, c: ps.hpr(p, c.eye)),
        ("hpr", ["gamma=2.5", "hull=qhull"], lambda p, c: ps.hpr(p, c.eye, gamma=2.5, hull="qhull")),
        ("hpr", ["kernel=exp", "gamma=-0.001"], lambda p, c: ps.hpr(p, c.eye, kernel="exp", gamma=-0.001)),
        ("raycast", [], lambda p, c: ps.raycast(p, c)),
        ("raycast", ["radius_factor=2", "width=640", "height=360"], lambda p, c: ps.raycast(p, c, radius_factor=2, width=640, height=360)),
        ("splat", [], lambda p, c: ps.splat_visibility(p, c)),
        ("splat", ["radius_px=3", "depth_tolerance=0.03"], lambda p, c: ps.splat_visibility(p, c, radius_px=3, depth_tolerance=0.03)),
    ],
)
def test_same_indices_as_the_command_line(dataset, method, sets, call):
    d, points, views = dataset
    for k in (0, 5):
        out = d / f"{method}-{k}-{'-'.join(sets)}.txt"
        args = ["visible", "--dataset", "sphere-plane-24000", "--view", str(k), "--method", method, "--out", str(out)]
        for s in sets:
            args += ["--set", s]
        run(*args)
        expected = read_indices(out)
        got = call(points, ps.Camera.from_json(views[k]))
        assert got.dtype == np.int64
        np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize(
    "method",
    ["hpr", "hpr-confidence", "hpr-approx", "robust", "raycast", "splat", "screenspace", "vardensity"],
)
def test_defaults_are_the_command_lines(dataset, method):
    """One default per method (the registry card's): `visible` given nothing, Python given
    nothing and Python given the setting `visible` says it ran give the same indices."""
    d, points, views = dataset
    out = d / f"default-{method}.txt"
    stdout = run("visible", "--dataset", "sphere-plane-24000", "--view", "0", "--method", method, "--out", str(out))
    lines = stdout.splitlines()
    assert lines[-1].startswith(f"method={method} ")
    assert lines[-2].startswith("setting=")
    ran = dict(kv.split("=", 1) for kv in lines[-2][len("setting="):].split(";") if kv)
    expected = read_indices(out)
    cam = ps.Camera.from_json(views[0])
    np.testing.assert_array_equal(ps.visible(method, points, cam), expected)
    np.testing.assert_array_equal(ps.visible(method, points, cam, **ran), expected)
    if method == "hpr":
        # HPR's default is gamma = auto with seed 2007 (Katz's gamma = 3 is one keyword away).
        assert ran["gamma"] == "auto" and ran["seed"] == "2007"
        np.testing.assert_array_equal(ps.hpr(points, cam.eye), expected)
        assert not np.array_equal(ps.hpr(points, cam.eye, gamma=3), expected)


def test_reference_and_files_as_the_command_line(tmp_path):
    scan = ROOT / "examples/own-data/scan.ply"
    mesh = ROOT / "examples/own-data/scene.off"
    cams = [
        ps.Camera.look_at("pinhole", [3, -4, 2.5], [0, 0, 0.3], [0, 0, 1], 1280, 720, fov_y_deg=50),
        ps.Camera.look_at("spherical", [1.5, -1.5, 1.2], [0.5, -0.5, 1.2], [0, 0, 1], 1024, 512),
        ps.Camera.look_at("orthographic", [0, 0, 5], [0, 0, 0], [0, 1, 0], 600, 600, view_width=5, view_height=5),
    ]
    views = tmp_path / "views.jsonl"
    views.write_text("".join(c.to_json() + "\n" for c in cams))
    points = ps.read_cloud(scan)["positions"]
    vertices, faces = ps.read_mesh(mesh)
    assert points.shape == (6000, 3) and faces.shape[1] == 3
    for method in ("reference", "raycast", "splat"):
        out = tmp_path / method
        run("visible", "--cloud", str(scan), "--mesh", str(mesh), "--views", str(views), "--view", "all",
            "--method", method, "--out", str(out))
        for k, c in enumerate(cams):
            expected = read_indices(out / f"view-{k}.txt")
            if method == "reference":
                got = ps.reference(vertices, faces, points, c)
            elif method == "raycast":
                got = ps.raycast(points, c)
            else:
                got = ps.splat_visibility(points, c)
            np.testing.assert_array_equal(got, expected, err_msg=f"{method} view {k}")


def test_the_issue_example_and_masks():
    p = np.random.default_rng(0).normal(size=(10000, 3))
    v = ps.hpr(p, [0, 0, 10], gamma=3)
    assert 1000 < len(v) < 5000
    assert np.all(np.diff(v) > 0)
    m = ps.hpr(p, [0, 0, 10], gamma=3, as_mask=True)
    assert m.dtype == np.bool_ and m.sum() == len(v)
    np.testing.assert_array_equal(np.flatnonzero(m), v)
    # float32 input gives the same answer as its float64 conversion.
    p32 = p.astype(np.float32)
    np.testing.assert_array_equal(ps.hpr(p32, [0, 0, 10]), ps.hpr(p32.astype(np.float64), [0, 0, 10]))
    # Fortran order and non-contiguous views are converted once.
    np.testing.assert_array_equal(ps.hpr(np.asfortranarray(p), [0, 0, 10], gamma=3), v)
    many = ps.hpr_many(p, [[0, 0, 10], [10, 0, 0]], gamma=3)
    np.testing.assert_array_equal(many[0], v)
    s = ps.score(v, v, len(p))
    assert s == {"precision": 1.0, "recall": 1.0, "f1": 1.0, "jaccard": 1.0}
    assert ps.score(m, m, len(p))["f1"] == 1.0


def test_hull_and_lod():
    rng = np.random.default_rng(1)
    p = rng.normal(size=(5000, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    own = ps.convex_hull_vertices(p)
    assert len(own) == 5000  # every point of a sphere is a vertex
    np.testing.assert_array_equal(own, ps.convex_hull_vertices(p, "qhull"))
    normals = p.copy()
    cam = ps.Camera.look_at("pinhole", [0, 0, 4], [0, 0, 0], [0, 1, 0], 640, 480, fov_y_deg=40)
    q = ps.QSplat(p, normals, 0.03)
    fine, coarse = q.select(cam, 1.0), q.select(cam, 16.0)
    assert len(coarse["radii"]) < len(fine["radii"]) <= 5000
    assert fine["centers"].shape == (len(fine["radii"]), 3)
    spt = ps.SequentialPointTree(p, normals, 0.06)
    assert ps.SequentialPointTree.epsilon_for_pixels(cam, 2.0) > 0
    cut = spt.select(cam, 2.0)
    assert 0 < len(cut["radii"]) < len(spt)
    assert len(spt.select(cam, epsilon_px=8.0)["radii"]) < len(cut["radii"])
    uv = rng.random((5000, 2))
    image = np.full((256, 256, 3), 128, np.uint8)
    image[:, 128:] = rng.integers(0, 255, size=(256, 128, 3), dtype=np.uint8)
    kept, factors = ps.srn_select(uv, image, scale=1.0, seed=3)
    busy = uv[kept, 0] >= 0.5
    # Flat texture (left half, u < 0.5): little masking, most points kept; noise (right half)
    # masks detail, so few are (measured: 86 % and 4 %).
    assert (~busy).sum() > 0.7 * (uv[:, 0] < 0.5).sum()
    assert busy.sum() < 0.2 * (uv[:, 0] >= 0.5).sum()
    assert np.all(factors >= 1.0)


def test_every_lod_method_through_the_registry():
    """`Lod` builds any LOD method of the registry by name and selects with the registry's
    keys, as the `lod` experiment does; errors speak of keyword arguments."""
    rng = np.random.default_rng(5)
    p = rng.normal(size=(4000, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    uv = rng.random((4000, 2))
    image = rng.integers(0, 255, size=(64, 64, 3), dtype=np.uint8)
    cam = ps.Camera.look_at("pinhole", [0, 0, 4], [0, 0, 0], [0, 1, 0], 320, 240, fov_y_deg=40)
    lod_names = {"qsplat", "spt", "srn", "random"}
    assert lod_names <= {m[0] for m in ps.methods()}
    for name in sorted(lod_names):
        # No normals: estimated (16 neighbours), as the lod experiment does for scans.
        lod = ps.Lod(name, p, uvs=uv, texture=image, seed=1)
        assert lod.method == name and lod.radius > 0 and lod.build_seconds >= 0
        s = lod.select(cam)  # the method's defaults
        k = len(s["radii"])
        assert 0 < k <= 4000, name
        assert s["centers"].shape == (k, 3) and s["colors"].shape == (k, 3)
        assert np.all((s["colors"] >= 0) & (s["colors"] <= 1)) and s["seconds"] >= 0
        np.testing.assert_allclose(np.linalg.norm(s["normals"], axis=1), 1.0, atol=1e-3)
    # The random baseline keeps about `fraction` of the points, splats grown by 1/sqrt(f).
    r = ps.Lod("random", p, p, seed=2)
    quarter = r.select(cam, fraction=0.25)
    assert abs(len(quarter["radii"]) - 1000) < 120
    np.testing.assert_allclose(quarter["radii"], 2.0 * r.radius, rtol=1e-6)
    # A list of cameras: one selection each, the structure built once.
    both = ps.Lod("qsplat", p, p).select([cam, cam], threshold_px=4)
    assert len(both) == 2 and len(both[0]["radii"]) == len(both[1]["radii"])
    with pytest.raises(ValueError, match="srn needs a texture"):
        ps.Lod("srn", p, p)
    with pytest.raises(ValueError, match="unknown level-of-detail method .*qsplat"):
        ps.Lod("octree", p, p)
    with pytest.raises(ValueError, match="fraction"):
        r.select(cam, fraction=3.0)
    with pytest.raises(ValueError, match="threshold_py"):
        ps.Lod("qsplat", p, p).select(cam, threshold_py=2)
    with pytest.raises(ValueError, match="colors or a texture"):
        ps.Lod("qsplat", p, p, colors=np.zeros((4000, 3)), texture=image)
    with pytest.raises(ValueError, match="point 7"):
        bad = p.copy()
        bad[7, 1] = np.nan
        ps.Lod("qsplat", bad, p)


def _zbuffer_folder(folder):
    """The repository's example z-buffer method copied into `folder` (its name the folder's),
    with the protocol helper it imports (from ../_shared, or beside it)."""
    folder.mkdir(parents=True)
    example = ROOT / "methods" / "example-zbuffer"
    shutil.copy(example / "zbuffer.py", folder / "zbuffer.py")
    shutil.copy(example / "method.toml", folder / "method.toml")
    shutil.copy(ROOT / "methods" / "_shared" / "pointsight_protocol.py", folder)


def test_an_external_method_loaded_from_python(tmp_path):
    """`load_methods` registers a method folder (any language, methods/README.md); `visible`
    then runs it by name through the kernel. The example is a point z-buffer, so its answer is
    computed here with numpy from the camera's own projection."""
    _zbuffer_folder(tmp_path / "methods" / "py-test-zbuffer")
    assert ps.load_methods(tmp_path / "methods") == ["py-test-zbuffer"]
    assert ps.load_methods(tmp_path / "methods") == []  # loading twice is harmless
    assert "py-test-zbuffer" in {m[0] for m in ps.methods()}
    rng = np.random.default_rng(6)
    p = rng.normal(size=(3000, 3))
    cam = ps.Camera.look_at("pinhole", [0, 0, 6], [0, 0, 0], [0, 1, 0], 40, 30, fov_y_deg=40)
    got = ps.visible("py-test-zbuffer", p, cam)
    q = cam.project(p)
    inside = np.isfinite(q[:, 2]) & (q[:, 0] >= 0) & (q[:, 0] < 40) & (q[:, 1] >= 0) & (q[:, 1] < 30)
    nearest = {}
    for k in np.flatnonzero(inside):
        px = (int(q[k, 0]), int(q[k, 1]))
        if px not in nearest or q[k, 2] < q[nearest[px], 2]:
            nearest[px] = k
    np.testing.assert_array_equal(got, np.sort(list(nearest.values())))
    assert 100 < len(got) < 1200
    # Two cameras: one answer each; a setting with the registry's key.
    many = ps.visible("py-test-zbuffer", p, [cam, cam], scale=2)
    assert len(many) == 2 and len(many[0]) >= len(got)
    with pytest.raises(ValueError, match="unknown method"):
        ps.visible("no-such-method", p, cam)
    with pytest.raises(ValueError, match="no-such-dir|No such file|not found|does not exist"):
        ps.load_methods(tmp_path / "no-such-dir")


def test_catalogues_side_by_side_know_only_their_own_methods(tmp_path):
    """A `Catalogue` is a value: one loaded with a folder runs its method; another, and the
    module's default, do not know it; an unknown catalogue type is refused."""
    _zbuffer_folder(tmp_path / "methods" / "py-side-zbuffer")
    mine = ps.Catalogue()
    assert mine.load(tmp_path / "methods") == ["py-side-zbuffer"]
    other = ps.Catalogue()
    assert "py-side-zbuffer" in mine.names() and "py-side-zbuffer" not in other.names()
    assert "hpr" in other.names()
    assert "py-side-zbuffer" in {m[0] for m in ps.methods(mine)}
    assert "py-side-zbuffer" not in {m[0] for m in ps.methods(other)}
    p = np.random.default_rng(7).normal(size=(500, 3))
    cam = ps.Camera.look_at("pinhole", [0, 0, 6], [0, 0, 0], [0, 1, 0], 40, 30, fov_y_deg=40)
    assert len(ps.visible("py-side-zbuffer", p, cam, catalogue=mine)) > 0
    with pytest.raises(ValueError, match="unknown method"):
        ps.visible("py-side-zbuffer", p, cam, catalogue=other)
    with pytest.raises(ValueError, match="unknown method"):
        ps.visible("py-side-zbuffer", p, cam)
    with pytest.raises(TypeError, match="Catalogue"):
        ps.visible("hpr", p, cam, catalogue="not a catalogue")


def test_an_external_lod_method_loaded_from_python(tmp_path):
    """A throwaway level-of-detail method is one folder (its card comes from its manifest,
    methods/README.md): `load_methods` registers it, `methods()` lists it with its parameters,
    and `Lod` builds and selects it through the kernel like the built-in ones."""
    folder = tmp_path / "methods" / "py-test-every-kth"
    folder.mkdir(parents=True)
    (folder / "method.toml").write_text(
        'protocol = 2\nkind = "lod"\nsummary = "test only: every k-th point"\n'
        'command = ["python3", "lod.py"]\n'
        '[params.k]\ndefault = "3"\nhelp = "keep one point in k"\n'
    )
    (folder / "lod.py").write_text(
        "import sys, json\n"
        "n = int(open(sys.argv[sys.argv.index('--points') + 1], 'rb').read(4000)"
        ".split(b'element vertex ')[1].split()[0])\n"
        "print(json.dumps({'built': True, 'seconds': 0.0, 'nodes': n, 'bytes': 0}), flush=True)\n"
        "for line in sys.stdin:\n"
        "    k = int(json.loads(line)['params'].get('k', '3'))\n"
        "    print(json.dumps({'visible': list(range(0, n, k)), 'radius': 0.05, 'seconds': 0.0}), flush=True)\n"
    )
    assert ps.load_methods(tmp_path / "methods") == ["py-test-every-kth"]
    listing = {m[0]: m for m in ps.methods()}
    assert listing["py-test-every-kth"][2] == [("k", "3", "keep one point in k")]
    rng = np.random.default_rng(8)
    p = rng.normal(size=(900, 3))
    cam = ps.Camera.look_at("pinhole", [0, 0, 6], [0, 0, 0], [0, 1, 0], 64, 48, fov_y_deg=40)
    lod = ps.Lod("py-test-every-kth", p, p / np.linalg.norm(p, axis=1, keepdims=True))
    assert len(lod.select(cam)["radii"]) == 300  # the program's own default, k = 3
    assert len(lod.select(cam, k=2)["radii"]) == 450
    with pytest.raises(ValueError, match="unexpected keyword argument m"):
        lod.select(cam, m=2)
    with pytest.raises(ValueError, match="level-of-detail method"):
        ps.visible("py-test-every-kth", p, cam)


def test_readers_on_files_of_other_tools():
    laz = ps.read_cloud(ROOT / "tests/data/formats/tiny.laz")
    np.testing.assert_array_equal(laz["classification"], [2, 2, 6, 1, 6])
    assert laz["positions"][0].tolist() == [500000.125, 4000000.25, 100.5]
    assert laz["colors"].dtype == np.uint8 and laz["colors"][0].tolist() == [255, 0, 0]
    # The documented return value: these keys (those the file has), these dtypes and shapes.
    assert set(laz) <= {"positions", "normals", "colors", "intensity", "classification", "scan", "faces", "scanner_positions"}
    assert laz["positions"].dtype == np.float64 and laz["positions"].shape == (5, 3)
    assert laz["classification"].dtype == np.uint8 and laz["classification"].shape == (5,)
    if "intensity" in laz:
        assert laz["intensity"].dtype == np.uint16
    six = ps.read_cloud(ROOT / "tests/data/formats/tiny.laz", classes=[6])
    assert len(six["positions"]) == 2
    e57 = ps.read_cloud(ROOT / "tests/data/formats/tiny.e57")
    assert e57["scanner_positions"].tolist()[1] == [10.0, 0.0, 0.0]
    assert e57["scanner_positions"].dtype == np.float64
    if "scan" in e57:
        assert e57["scan"].dtype == np.uint16 and e57["scan"].shape == (len(e57["positions"]),)
    assert ps.read_cloud(ROOT / "tests/data/formats/tiny.e57", scan=1)["positions"].shape == (5, 3)
    with pytest.raises(ValueError, match="read_mesh|faces"):
        ps.read_mesh(ROOT / "tests/data/formats/tiny.laz")


@pytest.mark.parametrize(
    "bad,exc,match",
    [
        (np.array([["a", "b", "c"]]), TypeError, "numbers"),
        (np.zeros((4, 2)), ValueError, r"shape \(N, 3\)"),
        (np.zeros((0, 3)), ValueError, "empty"),
        (np.array([[0, 0, np.nan], [1, 0, 0], [0, 1, 0], [0, 0, 1]]), ValueError, "point 0"),
        (np.zeros((4, 3), dtype=complex), TypeError, "complex"),
        ([[0, 0, 0], [1, 1]], TypeError, "numbers"),
        ("points", TypeError, "numbers"),
    ],
)
def test_bad_points(bad, exc, match):
    with pytest.raises(exc, match=match):
        ps.hpr(bad, [0, 0, 5])


def test_bad_parameters_and_cameras():
    p = np.random.default_rng(2).normal(size=(500, 3))
    with pytest.raises(ValueError, match="gamma"):
        ps.hpr(p, [0, 0, 5], gamma="lots")
    with pytest.raises(ValueError, match="hull"):
        ps.hpr(p, [0, 0, 5], hull="magic")
    with pytest.raises(ValueError, match="eye"):
        ps.hpr(p, [0, 0])
    with pytest.raises(ValueError):
        ps.hidden_point_removal(p, [0, 0, 5], -1.0)
    with pytest.raises(ValueError, match="unknown camera model"):
        ps.Camera.look_at("fisheye", [0, 0, 5], [0, 0, 0], [0, 1, 0], 10, 10)
    with pytest.raises(ValueError, match="coincide"):
        ps.Camera.look_at("spherical", [0, 0, 0], [0, 0, 0], [0, 1, 0], 10, 10)
    with pytest.raises(ValueError, match="field of view"):
        ps.Camera.look_at("pinhole", [0, 0, 5], [0, 0, 0], [0, 1, 0], 10, 10, fov_y_deg=-3)
    with pytest.raises(ValueError, match="malformed"):
        ps.Camera.from_json("{")
    ortho = ps.Camera.look_at("orthographic", [0, 0, 5], [0, 0, 0], [0, 1, 0], 10, 10, view_width=2, view_height=2)
    with pytest.raises(ValueError, match="radius"):
        ps.raycast(p, ortho, radius=-1.0)
    with pytest.raises(ValueError, match="face 0 refers to vertex 999"):
        ps.reference(p, np.array([[0, 1, 999]]), p, ortho)
    with pytest.raises(TypeError):
        ps.raycast(p, 42)
    with pytest.raises(ValueError, match="n must be"):
        ps.set_num_threads(-1)


def test_two_threads_at_once_and_a_thread_count():
    p = np.random.default_rng(3).normal(size=(20000, 3))
    expected = ps.hpr(p, [0, 0, 10])
    results = [None, None]

    def work(k):
        results[k] = ps.hpr(p, [0, 0, 10])

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        np.testing.assert_array_equal(r, expected)
    ps.set_num_threads(1)
    try:
        np.testing.assert_array_equal(ps.hpr(p, [0, 0, 10]), expected)
    finally:
        ps.set_num_threads(0)


def test_methods_listing_matches_the_cli_vocabulary():
    names = {m[0] for m in ps.methods()}
    assert {"hpr", "raycast", "splat", "reference", "exact"} <= names
    # The level-of-detail methods are listed too, with the registry's parameter names.
    assert {"qsplat", "spt", "srn", "random"} <= names
    qsplat_keys = {k for name, _, params in ps.methods() if name == "qsplat" for k, _, _ in params}
    assert qsplat_keys == {"threshold_px"}
    hpr_keys = {k for name, _, params in ps.methods() if name == "hpr" for k, _, _ in params}
    assert {"gamma", "radius", "kernel", "hull", "perturb", "seed"} == hpr_keys


def test_open3d_hidden_point_removal_if_installed():
    o3d = pytest.importorskip("open3d")
    rng = np.random.default_rng(4)
    p = rng.normal(size=(3000, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    p *= 1.0 + 0.05 * rng.random((3000, 1))
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p))
    eye = [0.0, 0.0, 4.0]
    radius = 100.0 * 2.2
    _, theirs = pcd.hidden_point_removal(eye, radius)
    ours = ps.hidden_point_removal(pcd, eye, radius)
    np.testing.assert_array_equal(ours, np.sort(np.asarray(theirs)))


def test_open3d_peer_through_the_external_protocol_if_installed(tmp_path):
    """CI installs Open3D (`just peers`): one view of a synthetic dataset through
    methods/open3d-hpr, so the adapter cannot rot; its set equals our exact HPR's there."""
    pytest.importorskip("open3d")
    out_peer, out_ours = tmp_path / "peer.txt", tmp_path / "ours.txt"
    stdout = run("visible", "--dataset", "sphere-20000", "--view", "3", "--method", "open3d-hpr", "--out", str(out_peer))
    assert stdout.splitlines()[-1].startswith("method=open3d-hpr points=20000 visible=")
    # The peer's default γ is 3; ours is `auto` (the card's default), so pair them at γ = 3.
    run("visible", "--dataset", "sphere-20000", "--view", "3", "--method", "hpr", "--set", "gamma=3", "--out", str(out_ours))
    np.testing.assert_array_equal(read_indices(out_peer), read_indices(out_ours))


def test_qsplat_selected_from_a_built_file(tmp_path):
    """A file `pointsight lod-build` wrote, opened with `QSplat.open`: the same splats as the
    tree built in memory from the same points, normals and leaf radius, read through a
    bounded cache."""
    rng = np.random.default_rng(3)
    n = 30000
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    p *= 1.0 + 0.01 * rng.random((n, 1))
    normals = p / np.linalg.norm(p, axis=1, keepdims=True)
    ply = tmp_path / "ball.ply"
    with open(ply, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\n" % n)
        for a in ("x", "y", "z"):
            f.write(f"property double {a}\n")
        for a in ("nx", "ny", "nz"):
            f.write(f"property float {a}\n")
        f.write("end_header\n")
        for q, m in zip(p.tolist(), normals.astype(np.float32).astype(np.float64).tolist()):
            f.write(" ".join(repr(v) for v in q + m) + "\n")
    out = run("lod-build", "--cloud", str(ply), "--out", str(tmp_path / "ball.qsplat"))
    radius = float(dict(kv.split("=") for kv in out.split())["leaf_radius"])
    built = ps.QSplat.open(tmp_path / "ball.qsplat", cache_bytes=1 << 20)
    assert len(built) > n
    mem = ps.QSplat(p, normals.astype(np.float32).astype(np.float64), radius)
    cams = [
        ps.Camera.look_at("pinhole", eye, [0, 0, 0], [0, 1, 0], 320, 240, fov_y_deg=50)
        for eye in ([0, 0, 4], [3, 1, -2], [0.2, 0.1, 1.6])
    ]
    for threshold in (0.5, 4.0):
        got = built.select(cams, threshold)
        want = mem.select(cams, threshold)
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g["centers"], w["centers"])
            np.testing.assert_array_equal(g["radii"], w["radii"])
            assert g["cache_bytes"] <= 1 << 20
            assert "bytes_read" in g and "bytes_read" not in w
    with pytest.raises(ValueError, match="corrupt|magic"):
        (tmp_path / "bad.qsplat").write_bytes(b"not a qsplat file")
        ps.QSplat.open(tmp_path / "bad.qsplat")
    # The same cloud as a sequential point tree, cut from its file: the in-memory tree's
    # cuts, splat for splat, within the file's quantisation (`spt::pack`: a centre within half a
    # step of its box's 16-bit sub-grid, at most the root box / 131,070; a normal within
    # 5e-5 rad; the radius exact).
    run("lod-build", "--cloud", str(ply), "--method", "spt", "--out", str(tmp_path / "ball.spt"))
    tree = ps.SequentialPointTree.open(tmp_path / "ball.spt")
    assert tree.method == "spt" and len(tree) > n
    mem = ps.SequentialPointTree(p, normals.astype(np.float32).astype(np.float64), 2.0 * radius)
    for eps in (0.5, 4.0):
        got = tree.select(cams, eps)
        want = mem.select(cams, eps)
        for g, w in zip(got, want):
            assert len(g["centers"]) > 0
            root = float(np.ptp(p, axis=0).max()) + 4.0 * radius
            np.testing.assert_allclose(g["centers"], w["centers"], rtol=0, atol=root / 131070 + 1e-6)
            np.testing.assert_array_equal(g["radii"], w["radii"])
            np.testing.assert_allclose(g["normals"], w["normals"], rtol=0, atol=5e-5)
            assert g["bytes_read"] > 0
    with pytest.raises(ValueError, match="not a sequential point tree"):
        ps.SequentialPointTree.open(tmp_path / "ball.qsplat")

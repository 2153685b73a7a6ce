"""VTK's vtkSelectVisiblePoints as a pointsight external method (protocol 3).

The cloud is drawn once per request as VTK points of `point_size` pixels (a square sprite per
point, VTK's OpenGL point rendering) into an offscreen render window (EGL, else OSMesa: no
display needed), the camera set from pointsight's pinhole camera (eye, forward, up, vertical
field of view, principal point as VTK's window centre), multisampling off;
`vtkSelectVisiblePoints` then moves each point toward the eye along the view axis by
`ToleranceWorld` and keeps it when it is nearer than the z-buffer at the pixel it then projects
to. The point's index rides along as point data, so the selection maps back.

Against pointsight's `splat`: this is its `rule=sprite` (a square of `point_size` = 2 ×
`radius_px` pixels, one world tolerance per view, `depth_tolerance` × the distance from the eye
to the cloud's centre), which the `rule` key here only names so that the two pair; its default
disc rule (a disc of radius `radius_px`, a relative tolerance per point) is another selection. The render window's class is on the
stderr log's first line (a test checks it is an offscreen one).

One process serves every setting on its cloud. Per cloud, once: the points, their centre and
radius, VTK's point data with the indices, and a scene (renderer, render window, selection)
for the start-up setting's `multisamples` (0 in protocol 3), whose set-up (VTK's objects, the
window's GL context, a first draw that uploads the points) is timed and reported on the
protocol's optional `built` line, apart from the per-request times. Per request, from its
setting: the point size, the depth tolerance and the window's size (`width` x `height`, else
the view's; a new size's buffers are made by a draw before the timed one). A render window's
multisampling is fixed when its GL context is made, so another `multisamples` gets a scene of
its own, made when first asked for (timed apart, on standard error) and kept.
"""

import os
import sys
import time

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import vtk  # noqa: E402
from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray, vtk_to_numpy  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "_shared"))
import pointsight_protocol as protocol  # noqa: E402


def read_points(path):
    rows = protocol.read_rows(path)
    return np.stack([rows["x"], rows["y"], rows["z"]], axis=1).astype(np.float64)


class Scene:
    """A render window with its renderer, the cloud's actor and the selection, at one
    multisampling."""

    def __init__(self, poly, multisamples):
        verts = vtk.vtkVertexGlyphFilter()
        verts.SetInputData(poly)
        mapper = vtk.vtkPolyDataMapper()
        mapper.SetInputConnection(verts.GetOutputPort())
        mapper.ScalarVisibilityOff()
        self.actor = vtk.vtkActor()
        self.actor.SetMapper(mapper)
        self.actor.GetProperty().SetRepresentationToPoints()
        self.ren = vtk.vtkRenderer()
        self.ren.AddActor(self.actor)
        self.window = vtk.vtkRenderWindow()
        self.window.SetOffScreenRendering(1)
        # Multisampling resolves the depth buffer across samples, so the buffer the selection
        # reads is no longer the nearest point's depth per pixel (VTK's default here is 4
        # samples: against an exact one-pixel z-buffer the selected set falls from Jaccard
        # 0.954 to 0.66).
        self.window.SetMultiSamples(multisamples)
        self.window.AddRenderer(self.ren)
        self.select = vtk.vtkSelectVisiblePoints()
        self.select.SetInputData(poly)
        self.select.SetRenderer(self.ren)
        self.select.SetTolerance(0.0)

    def first_draw(self):
        """The window's GL context and one draw, which uploads the points."""
        self.window.SetSize(64, 64)
        self.ren.ResetCamera()
        self.window.Render()
        return self


def multisamples_of(setting):
    multisamples = int(setting.get("multisamples", "0"))
    if multisamples < 0:
        raise ValueError(f"vtk-zbuffer: multisamples={multisamples}: must be >= 0")
    return multisamples


def main():
    args, params = protocol.arguments(
        lambda ap: ap.add_argument("--window-class", action="store_true", help="print the window class, exit")
    )
    if args.window_class:
        window = vtk.vtkRenderWindow()
        window.SetOffScreenRendering(1)
        window.AddRenderer(vtk.vtkRenderer())
        window.SetSize(8, 8)
        window.Render()
        print(window.GetClassName())
        return
    if args.points is None:
        raise SystemExit("vtk-zbuffer: --points FILE is required")

    points = read_points(args.points)
    start = time.perf_counter()
    centre = points.mean(axis=0)
    radius = float(np.max(np.linalg.norm(points - centre, axis=1)))
    vpoints = vtk.vtkPoints()
    vpoints.SetData(numpy_to_vtk(points, deep=True))
    poly = vtk.vtkPolyData()
    poly.SetPoints(vpoints)
    ids = numpy_to_vtkIdTypeArray(np.arange(len(points), dtype=np.int64), deep=True)
    ids.SetName("index")
    poly.GetPointData().AddArray(ids)
    # The start-up setting's scene (protocols 1 and 2; protocol 3 passes none: the default);
    # a setting that is not valid is refused by its requests.
    try:
        first_multisamples = multisamples_of(params)
    except ValueError:
        first_multisamples = 0
    scene = Scene(poly, first_multisamples)
    print(f"vtk-zbuffer: render window {scene.window.GetClassName()}", file=sys.stderr, flush=True)
    scenes = {first_multisamples: scene.first_draw()}
    # The per-cloud set-up, reported apart from the requests (the protocol's optional first
    # line): the VTK objects, the window's GL context and one draw, which uploads the points.
    protocol.built(time.perf_counter() - start)

    def answer(request):
        cam = request["camera"]
        if cam["model"] != "pinhole":
            raise ValueError(f"vtk-zbuffer takes pinhole cameras, not {cam['model']}")
        setting = protocol.setting(request, params)
        point_size = float(setting.get("point_size", "4"))
        depth_tolerance = float(setting.get("depth_tolerance", "0.01"))
        if setting.get("rule", "sprite") != "sprite":
            raise ValueError(f"vtk-zbuffer: rule={setting['rule']}: VTK draws square sprites (sprite only)")
        multisamples = multisamples_of(setting)
        w = int(setting["width"]) if "width" in setting else cam["width"]
        h = int(setting["height"]) if "height" in setting else cam["height"]
        if multisamples not in scenes:
            t = time.perf_counter()
            scenes[multisamples] = Scene(poly, multisamples).first_draw()
            print(f"vtk-zbuffer: scene with {multisamples} samples made in "
                  f"{time.perf_counter() - t:.6f} s", file=sys.stderr, flush=True)
        scene = scenes[multisamples]
        scene.actor.GetProperty().SetPointSize(point_size)
        sx, sy = w / cam["width"], h / cam["height"]
        cx, cy = cam["cx"] * sx, cam["cy"] * sy
        m = np.array(cam["camera_to_world"], dtype=np.float64)
        eye, forward, down = m[:3, 3], m[:3, 2], m[:3, 1]
        vc = scene.ren.GetActiveCamera()
        vc.SetPosition(*eye)
        vc.SetFocalPoint(*(eye + forward))
        vc.SetViewUp(*(-down))
        vc.SetViewAngle(float(cam["fov_y_deg"]))
        # Principal point: VTK's window centre, in [-1, 1] (y up).
        vc.SetWindowCenter(-(cx - w / 2) / (w / 2), (cy - h / 2) / (h / 2))
        distance = float(np.linalg.norm(centre - eye))
        near = max(distance - radius, 1e-3 * distance)
        vc.SetClippingRange(near, distance + radius)
        scene.select.SetToleranceWorld(depth_tolerance * distance)
        if tuple(scene.window.GetSize()) != (w, h):
            # Another size (a setting's width x height, another view's): the window's buffers
            # are remade at its next draw, here, apart from the request's time.
            scene.window.SetSize(w, h)
            scene.window.Render()
        t0 = time.perf_counter()
        scene.window.Render()
        scene.select.Modified()
        scene.select.Update()
        out = scene.select.GetOutput().GetPointData().GetArray("index")
        visible = np.sort(vtk_to_numpy(out)) if out is not None else np.array([], np.int64)
        seconds = time.perf_counter() - t0
        return {"visible": visible.tolist(), "seconds": seconds}

    protocol.serve(answer)


if __name__ == "__main__":
    main()

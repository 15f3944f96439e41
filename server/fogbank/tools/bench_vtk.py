"""VTK's frame of fogbank's own terrain, for `fogbank bench`: the path trame and PyVista
take (vtkPolyDataMapper, vtkRenderWindow offscreen on EGL, pixels read back, JPEG q80 by
the same encoder as fogbank's frames), with the camera orbiting. No fog: VTK's frame of
the unfogged terrain is what fogbank's foggy frame is compared with.

VTK is an optional benchmark dependency (`pip install -e '.[bench]'`). It runs in a
child process of its own, so that its EGL context and fogbank's never share a process:

    python -m fogbank.tools.bench_vtk MESH.npz WIDTH HEIGHT FRAMES
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np


def available() -> str | None:
    """VTK's version, or None where it is not installed."""
    try:
        out = subprocess.run([sys.executable, "-c", "import vtk; print(vtk.vtkVersion.GetVTKVersion())"],
                             capture_output=True, text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def scene_triangles(name: str = "countryside") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """fogbank's scene as one indexed triangle mesh: positions (N, 3), normals (N, 3),
    triangles (M, 3): the detailed terrain, the far land, water, house, bridge and trees."""
    from fogbank.scene import meshes
    m = meshes.build(name)
    pos = [m.terrain_vertices[:, :3]]
    nrm = [m.terrain_vertices[:, 3:6]]
    full = getattr(m, "full_detail", len(m.terrain_indices))   # the coarser levels follow it
    tris = [m.terrain_indices[:full].reshape(-1, 3).astype(np.int64)]
    n0 = len(pos[0])
    objects = m.objects[:m.objects_full] if getattr(m, "objects_full", -1) >= 0 else m.objects   # coarse trees follow
    pos.append(objects[:, :3])
    nrm.append(objects[:, 3:6])
    tris.append(np.arange(len(objects), dtype=np.int64).reshape(-1, 3) + n0)
    return np.concatenate(pos), np.concatenate(nrm), np.concatenate(tris)


def orbit(width: int, height: int, frames: int = 20, scene: str = "countryside") -> dict:
    """Median ms of VTK's orbiting frame (render, read back, JPEG q80) in a child process."""
    pos, nrm, tris = scene_triangles(scene)
    with tempfile.TemporaryDirectory(prefix="fogbank-vtk-") as tmp:
        path = os.path.join(tmp, "mesh.npz")
        np.savez(path, pos=pos, nrm=nrm, tris=tris)
        env = {**os.environ, "VTK_DEFAULT_OPENGL_WINDOW": os.environ.get("VTK_DEFAULT_OPENGL_WINDOW",
                                                                          "vtkEGLRenderWindow")}
        out = subprocess.run([sys.executable, "-m", "fogbank.tools.bench_vtk", path, str(width), str(height),
                              str(frames)], capture_output=True, text=True, timeout=600, env=env)
    if out.returncode != 0:
        raise RuntimeError(f"the VTK child failed: {out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _child(path: str, width: int, height: int, frames: int) -> dict:
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray, vtk_to_numpy

    from fogbank.model import presets as P
    from fogbank.model.params import FogParams
    from fogbank.render.encode import encode
    from fogbank.scene import camera as cam

    d = np.load(path)
    pos, nrm, tris = d["pos"], d["nrm"], d["tris"]
    poly = vtk.vtkPolyData()
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(pos, dtype=np.float32), deep=True))
    poly.SetPoints(pts)
    cells = np.concatenate([np.full((len(tris), 1), 3, np.int64), tris], axis=1).ravel()
    ca = vtk.vtkCellArray()
    ca.ImportLegacyFormat(numpy_to_vtkIdTypeArray(cells, deep=True))
    poly.SetPolys(ca)
    normals = numpy_to_vtk(np.ascontiguousarray(nrm, dtype=np.float32), deep=True)
    normals.SetName("Normals")
    poly.GetPointData().SetNormals(normals)
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputData(poly)
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetColor(0.25, 0.35, 0.15)
    ren = vtk.vtkRenderer()
    ren.AddActor(actor)
    ren.SetBackground(0.6, 0.7, 0.8)
    rw = vtk.vtkRenderWindow()
    rw.SetOffScreenRendering(1)
    rw.SetSize(width, height)
    rw.AddRenderer(ren)
    look = FogParams.model_validate(P.preset_dict("default"))
    c = look.camera
    camera = ren.GetActiveCamera()
    camera.SetViewAngle(c.fov)
    camera.SetClippingRange(cam.NEAR, cam.FAR)

    def frame(i: int) -> float:
        fwd, _, up = cam.basis(c.model_copy(update={"yaw": c.yaw + 2.0 * i}))
        camera.SetPosition(*c.position)
        camera.SetFocalPoint(*(np.asarray(c.position) + fwd))
        camera.SetViewUp(*up)
        camera.SetClippingRange(cam.NEAR, cam.FAR)
        t0 = time.perf_counter()
        rw.Render()
        arr = vtk.vtkUnsignedCharArray()
        rw.GetPixelData(0, 0, width - 1, height - 1, 1, arr, 0)
        img = vtk_to_numpy(arr).reshape(height, width, 3)[::-1]
        data = encode(img, "jpg", 80)
        if os.environ.get("FOGBANK_VTK_FRAME"):   # look at what was timed
            with open(os.environ["FOGBANK_VTK_FRAME"], "wb") as fh:
                fh.write(data)
        return (time.perf_counter() - t0) * 1000
    for i in range(3):
        frame(i)
    ms = [frame(i) for i in range(3, 3 + frames)]
    info = rw.ReportCapabilities()
    renderer = next((line.split(":", 1)[1].strip() for line in info.splitlines()
                     if "OpenGL renderer string" in line), "?")
    return {"ms": statistics.median(ms), "triangles": int(len(tris)), "vtk": vtk.vtkVersion.GetVTKVersion(),
            "gl": renderer, "window": rw.GetClassName()}


if __name__ == "__main__":
    print(json.dumps(_child(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]))))

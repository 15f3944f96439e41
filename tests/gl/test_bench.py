"""The benchmark's pieces that carry meaning: the raymarched comparison converges to the
closed forms (so its step counts are honest), and the report is written from results."""

from __future__ import annotations

import numpy as np
import pytest

from fogbank.render.probes import fog_only
from fogbank.tools.bench import _kind_looks, _reference, markdown


@pytest.mark.parametrize("kind", ["homogeneous", "height", "cosine", "polynomial", "potential", "sphere"])
def test_raymarch_converges_to_the_closed_form(renderer, kind):
    still = _kind_looks()[kind].model_copy(update={"width": 160, "height": 90})
    _, T_an, invd, view = fog_only(renderer, still)
    ref = _reference(still, invd.astype(np.float64), view)
    assert np.abs(T_an - ref).max() < 1e-3
    errs = []
    for steps in (4, 64, 1024):
        _, T_rm, _, _ = fog_only(renderer, still, raymarch_steps=steps)
        errs.append(np.abs(T_rm - ref).max())
    assert errs[-1] < 2e-3
    assert errs[-1] <= max(errs[0], 1e-4)     # more steps never worse (beyond float32 noise)


def test_markdown_report_from_results():
    res = {"command": "fogbank bench", "cpu": "cpu", "gl": {"renderer": "r", "version": "4.5"}, "date": "d",
           "analytic_vs_raymarch": [{"kind": "sphere", "analytic_ms": 2.0, "analytic_max_err": 1e-5,
                                     "raymarch_steps": 100, "raymarch_max_err": 0.003, "raymarch_ms": 30.0,
                                     "speedup": 15.0}],
           "biri_table1": [{"fog": "Constant", "fog_texture": "800x600", "fps": 9.0}],
           "gawron": {"fog_ms": 1.0, "single_ms": 2.0, "separate_ms": 3.0, "single_over_separate": 0.67},
           "streaming": [{"size": "640x360", "camera": "still", "delivered_fps": 50.0, "render_encode_fps": 55.0,
                          "ratio": 0.91, "server_render_ms": 10.0, "server_encode_ms": 2.0, "frame_kb": 9.0},
                         {"size": "640x360", "latency": {"p50_ms": 30, "p95_ms": 40, "p99_ms": 50, "n": 20}}],
           "concurrency": [{"clients": 1, "per_client_fps": [50.0], "aggregate_fps": 50.0, "fairness": 1.0,
                            "server_rss_mb": 600.0}],
           "stills_ms": {"png": 100.0, "jpg": 50.0, "webp": 80.0}}
    md = markdown(res)
    assert "| 1 | 640x360 | 50.0 | 50.0 - 50.0 | 1.00 | 600 |" in md
    # an earlier code's server, run right after: its figures beside each row
    res["concurrency"].append({"clients": 2, "size": "1280x720", "per_client_fps": [10.0, 12.0],
                               "aggregate_fps": 22.0, "fairness": 0.83, "server_rss_mb": 700.0})
    res["concurrency_before"] = [{"clients": 2, "size": "1280x720", "per_client_fps": [0.0, 5.5],
                                  "aggregate_fps": 5.5, "fairness": 0.0, "server_rss_mb": 650.0}]
    md = markdown(res)
    assert "| 2 | 1280x720 | 22.0 | 10.0 - 12.0 | 0.83 | 700 | 5.5 | 0.0 - 5.5 |" in md
    assert "| 1 | 640x360 | 50.0 | 50.0 - 50.0 | 1.00 | 600 | - | - |" in md
    assert "| sphere | 2.0 | 1.0e-05 | 100 | 30.0 | 15.0x |" in md
    assert "| Constant | 800x600 | 9.0 | 512x512 | 6.6 |" in md
    assert "| 640x360 | 30 | 40 | 50 |" in md


def test_the_lit_cost_is_reported_with_its_rounds_and_ratio():
    from fogbank.tools.bench import lit_markdown
    lit = {"lit, medium grid": {"ms": 60.0, "rounds": [61.0, 60.0, 59.0], "vs_before": 1.2},
           "unlit": {"ms": 45.0, "rounds": [45.0], "vs_before": 0.9},
           "before": {"ms": 50.0, "rounds": [50.0], "tree": "/tmp/old/server"}}
    md = "\n".join(lit_markdown(lit))
    assert "| lit, medium grid | 60.0 | 61.0, 60.0, 59.0 | 1.20x |" in md
    assert "| before (/tmp/old/server) | 50.0 | 50.0 | - |" in md


def test_a_drags_preview_cost_is_reported_with_its_rounds_and_ratio():
    from fogbank.tools.bench import preview_markdown
    prev = {"640x360 now": {"ms": 46.0, "rounds": [46.0, 47.5], "vs_before": 0.68},
            "640x360 before": {"ms": 68.0, "rounds": [68.0, 66.0], "tree": "/tmp/old/server"}}
    md = "\n".join(preview_markdown(prev))
    assert "| 640x360 now | 46.0 | 46.0, 47.5 | 0.68x |" in md
    assert "| 640x360 before (/tmp/old/server) | 68.0 | 68.0, 66.0 | - |" in md


def test_a_drags_preview_probe_runs_alone_in_a_fresh_process():
    """preview_cost ships preview_orbit's source to a fresh process (an earlier checkout's
    bench has none): it runs there with nothing of this module."""
    import inspect
    import json
    import subprocess
    import sys

    from fogbank.tools import bench
    probe = bench._PREVIEW_PROBE.format(source=inspect.getsource(bench.preview_orbit))
    assert "fogbank.tools.bench" not in probe
    out = subprocess.run([sys.executable, "-c", probe, "160", "90"], capture_output=True, text=True,
                         timeout=300, check=True).stdout
    assert 0 < float(json.loads(out.strip().splitlines()[-1])) < 5000


def test_process_boundary_is_measured_through_real_workers():
    from fogbank.tools.bench import process_boundary
    pb = process_boundary(n=20)
    assert set(pb) == {"noop_p50_ms", "noop_p90_ms", "frame_handover_p50_ms", "frame_handover_p90_ms"}
    assert 0 < pb["noop_p50_ms"] <= pb["noop_p90_ms"]
    assert 0 < pb["frame_handover_p50_ms"] <= pb["frame_handover_p90_ms"]
    res = {"command": "c", "cpu": "c", "gl": {"renderer": "r", "version": "v"}, "date": "d",
           "analytic_vs_raymarch": [], "biri_table1": [],
           "gawron": {"fog_ms": 1.0, "single_ms": 2.0, "separate_ms": 3.0, "single_over_separate": 0.67},
           "streaming": [], "concurrency": [], "stills_ms": {}, "process_boundary": pb}
    assert "## 7. The process boundary" in markdown(res)


def test_the_lit_cost_runs_each_light_in_a_fresh_process_and_sees_the_grid(renderer):
    """lit_cost's probe: a still camera's 720p frame in a fresh process of the given
    tree's code, with the look's light changed. The light grid's pass costs time when the
    look is lit and nothing when it is not (the frame then has no grid). In this process
    the session's renderer draws: a second GL context made current here would leave the
    session's objects to be drawn in it (a segfault in a later test)."""
    from pathlib import Path
    from fogbank.tools.bench import _probe, where_the_time_goes
    assert _probe(str(Path(__file__).parents[2] / "server"), 1, {"light_quality": "low"}) > 0.0
    lit = where_the_time_goes(renderer, 320, 180, n=2, orbit=False)
    flat = where_the_time_goes(renderer, 320, 180, n=2, orbit=False, effects={"lit": False, "shafts": 0.0})
    renderer.drop_slot("bench-still")
    assert lit["light"] > 10 * flat["light"]


def figures(fps720, lat, ratio):
    """What targets() returns, with the figures the tests vary."""
    return {"drag_1280x720": {"fps": fps720, "width": 640, "render_ms": 40},
            "still_1280x720": {"fps": 41.0}, "drag_640x360": {"fps": 20.0},
            "orbit_1280x720_nomsaa_ms": 100.0, "orbit_1280x720_msaa_ms": 200.0,
            "orbit_640x360_nomsaa_ms": 40.0, "orbit_640x360_msaa_ms": 90.0,
            "vtk": {"version": "9", "gl": "llvmpipe", "triangles": 5, "ms_1280x720": 300.0,
                    "ms_640x360": 80.0, "fogbank_ms_1280x720": 300.0 / ratio, "ratio_1280x720": ratio},
            "where_720p": {"scene": 50.0},
            "costly": [{"look": "16 x sphere", "p50_ms": 50, "p95_ms": lat, "max_ms": lat, "preview_width": 480,
                        "render_ms": 30}, {"look": "16 x height", "p50_ms": 20, "p95_ms": 60, "max_ms": 70,
                                           "preview_width": 960, "render_ms": 10}],
            "workers": [{"workers": 1, "aggregate_fps": 20.0}, {"workers": 2, "aggregate_fps": 25.0}],
            "analytic": {"cosine": 12.0, "potential": 9.0},
            "sun_drag": {"p50_ms": 40, "p95_ms": 0.3 * lat, "max_ms": 0.4 * lat, "preview_width": 720}}


def test_the_targets_table_reads_each_figure_and_judges_it_against_its_target():
    """Issue 13's table: each target's figure from the results, before and now, and 'met'
    by the target's own direction (fps and ratios at least, latency at most)."""
    from fogbank.tools.bench import targets_markdown

    res = {"targets": figures(30.0, 240.0, 3.5), "before": {"version": "abc", "targets": figures(9.8, 900.0, 1.2)}}
    md = "\n".join(targets_markdown(res))
    # the delivered figures of an earlier code's server run in the same rounds replace the
    # separate run's, and get a table of their own with every round and the ratio
    t = figures(30.0, 240.0, 3.5)
    t["drag_1280x720"]["rounds"] = [28.0, 30.0, 35.0]
    t["before_interleaved"] = {"tree": "/tmp/before/server",
                               **{k: {"fps": v, "rounds": [v - 1, v, v + 2]} for k, v in
                                  (("drag_1280x720", 20.0), ("still_1280x720", 25.0), ("drag_640x360", 16.0))},
                               "sun_drag": {"p95_ms": 410.0}}
    md2 = "\n".join(targets_markdown({"targets": t, "before": res["before"]}))
    assert "| the sun dragged, default look, 960x540: control-to-frame p95 | 410.0 ms | 72.0 ms |" in md2
    assert "and the sun drag's a server of that code run right after this one's" in md2
    assert "| 1280x720 orbiting, delivered to a dragging client | 20.0 fps | 30.0 fps | >= 24 fps | yes |" in md2
    assert "| drag_1280x720 | 30.0 | 28.0, 30.0, 35.0 | 640 | 40 |" in md2
    assert "| drag_1280x720 | 20.0 | 19.0, 20.0, 22.0 | 30.0 | 28.0, 30.0, 35.0 | 1.50 |" in md2
    assert "| 16 layers, 960x540: control-to-frame p95, worst look | 900.0 ms | 240.0 ms | <= 250 ms | yes |" in md2
    assert "| 1280x720 orbiting, delivered to a dragging client | 9.8 fps | 30.0 fps | >= 24 fps | yes |" in md
    assert "| 1280x720, still camera, delivered | 41.0 fps | 41.0 fps | >= 40 fps | yes |" in md
    assert "| 640x360 orbiting, delivered to a dragging client | 20.0 fps | 20.0 fps | >= 50 fps | no |" in md
    assert "| VTK's unfogged 720p frame / fogbank's foggy one (no MSAA) | 1.20x | 3.50x | >= 3x | yes |" in md
    assert "| 16 layers, 960x540: control-to-frame p95, worst look | 900.0 ms | 240.0 ms | <= 250 ms | yes |" in md
    assert "| analytic / raymarch of equal accuracy, potential | 9.00x | 9.00x | >= 10x | no |" in md
    assert "| 2 render workers / 1, aggregate fps | 1.25x | 1.25x | - | - |" in md
    assert "| 16 x sphere | 50 | 240 | 240 | 480 | 30 | 900 |" in md
    assert "| the sun dragged, default look, 960x540: control-to-frame p95 | 270.0 ms | 72.0 ms | <= 250 ms | yes |" in md
    # a 'before' that did not measure it (an earlier version's bench.json) says so
    del res["before"]["targets"]["sun_drag"]
    assert ("| the sun dragged, default look, 960x540: control-to-frame p95 | - | 72.0 ms | <= 250 ms | yes |"
            in "\n".join(targets_markdown(res)))



def test_the_report_says_what_before_is_and_scales_every_worker_row_by_one_worker():
    """The sentence over the targets names what 'before' holds in this run, and the
    workers table divides each row by the one-worker row, however many rows it has."""
    from fogbank.tools.bench import targets_markdown
    t = figures(30.0, 240.0, 3.5)
    t["workers"] = [{"workers": 1, "aggregate_fps": 100.0}, {"workers": 2, "aggregate_fps": 210.0},
                    {"workers": 4, "aggregate_fps": 350.0}]
    md = "\n".join(targets_markdown({"targets": t}))
    assert "no earlier version was measured" in md
    assert "| 2 | 210.0 | 2.10x |" in md and "| 4 | 350.0 | 3.50x |" in md and "| 1 | 100.0 | 1.00x |" in md
    assert "| 2 render workers / 1, aggregate fps | - | 2.10x | - | - |" in md
    t["before_interleaved"] = {"tree": "/tmp/old/server", **{k: {"fps": 20.0} for k in
                                                            ("drag_1280x720", "still_1280x720", "drag_640x360")}}
    md = "\n".join(targets_markdown({"targets": t, "before": {"version": "abc", "targets": {}}}))
    assert "'before' is the benchmark of abc read from its bench.json" in md
    assert "a server of the code in `/tmp/old/server`, run in turn with this one's" in md
    assert "faster machine" not in md


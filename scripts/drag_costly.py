"""Frames a client gets while it drags the camera as the page does (interact on, a camera
move and an ack for every frame), for a costly look: the default preset plus five more
layers (nine in all) at 960x540, and for the default look. Prints delivered fps, the
median preview width and the server's median render time. Starts its own server on
127.0.0.1 (stopped by PID), with the code on PYTHONPATH:

    .venv/bin/python scripts/drag_costly.py
    PYTHONPATH=<checkout of another commit>/server .venv/bin/python scripts/drag_costly.py
"""

from __future__ import annotations

import asyncio

from fogbank.model import presets as P
from fogbank.model.params import FogParams
from fogbank.model.urlstate import encode
from fogbank.tools.bench_stream import delivered_fps
from fogbank.tools.child import ChildServer


def costly_query() -> str:
    look = P.preset_dict("default")
    look["layers"] += [{"kind": "cosine", "density": 0.004, "scale": 30.0},
                       {"kind": "potential", "center": (10.0, 6.0, 20.0), "strength": 0.5},
                       {"kind": "sphere", "center": (-20.0, 8.0, 30.0), "radius": 20.0, "density": 0.02},
                       {"kind": "box", "center": (0.0, 4.0, 0.0), "density": 0.01},
                       {"kind": "ellipsoid", "center": (30.0, 6.0, -10.0), "density": 0.02}]
    return encode(FogParams.model_validate(look)) + "&play=0"


def main() -> None:
    srv = ChildServer()
    try:
        url = srv.url.replace("http", "ws", 1)
        for name, q in (("default (4 layers)", "v=1&play=0"), ("costly (9 layers)", costly_query())):
            r = asyncio.run(delivered_fps(url, q, 960, 540, seconds=8.0, orbit=True, drag=True))
            print(f"{name:20s} dragging at 960x540: {r['fps']:5.1f} fps delivered, preview width "
                  f"{r.get('width', 0):4.0f} px (median), render {r.get('render_ms', 0):6.1f} ms (median)")
    finally:
        srv.stop()


if __name__ == "__main__":
    main()

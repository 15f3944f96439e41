"""The sun dragged over the default look at 960x540, as `fogbank bench` measures it
(tools/bench.py sun_drag_latency: interact on, the sun's azimuth 2 degrees further every
150 ms while time runs, each change to the first frame that shows it), on a server of this
checkout and of each `server` folder named, in turn, for REPS rounds. Each server is
started on 127.0.0.1 and stopped by PID; this checkout's code is the client.

    .venv/bin/python scripts/sun_drag.py /tmp/before/server      # REPS=3 by default
"""

from __future__ import annotations

import os
import sys


def main(trees: list[str], reps: int) -> None:
    from fogbank.tools.bench import _tree_env, sun_drag_latency
    from fogbank.tools.child import ChildServer
    for rep in range(reps):
        for tree in [None, *trees]:
            srv = ChildServer(env=_tree_env(tree) if tree else None)
            try:
                print(f"round {rep}, {tree or 'this checkout'}:", flush=True)
                sun_drag_latency(srv)
            finally:
                srv.stop()


if __name__ == "__main__":
    main(sys.argv[1:], int(os.environ.get("REPS", "3")))

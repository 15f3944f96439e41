"""A render pass: a name, what it reads and writes, and `run(renderer, frame)`."""

from __future__ import annotations

# what a frame brings before any pass runs; gbuffer.held is what earlier frames of its slot
# left with the scene pass (a still camera's held fog and composite inputs, passes/fog.py),
# gbuffer.warp_base and out_base the preview scene pass and finished frame that a turning
# drag's previews warp (render/reproject.py)
FRAME_INPUTS = frozenset({"look", "look.sun", "view", "meshes", "fog_plan", "gbuffer.held", "gbuffer.warp_base",
                          "gbuffer.out_base"})


class Pass:
    name: str = ""
    reads: tuple[str, ...] = ()
    writes: tuple[str, ...] = ()

    def run(self, r, f) -> None:   # r: Renderer, f: Frame
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{self.name}({', '.join(self.reads)} -> {', '.join(self.writes)})"

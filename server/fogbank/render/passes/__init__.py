"""The frame's passes, in order. Each declares what it reads and what it writes; the
frame's inputs are the look, the view and the fog plan (render/frame.py).

    shadow     look.sun, meshes              -> shadow_map
    scene      meshes, shadow_map, view,     -> scene_target (cleared; a turning drag's
               gbuffer.warp_base                preview warps an earlier one's, and draws
                                                only what that one did not see)
    sky        look.sun, view, scene_target  -> scene_target (where no surface is), and
                                                a preview's whole pass: gbuffer.warp_base
    resolve    scene_target                  -> gbuffer (near and far surface per pixel)
    light      fog_plan, view, shadow_map    -> light_grid (lit looks: the sunlit share of
                                                the in-scattered light along coarse rays)
    fog        gbuffer.invdist, fog_plan,    -> fog (and gbuffer.held: a still camera's
               light_grid                       time-invariant fog, drawn once)
    fog_filter fog, fog_plan                 -> fog (3x3, jittered looks only)
    particles  gbuffer.invdist, fog_plan,    -> fog (clarity multiplied in, their light
               light_grid                       composited over the fog's)
    composite  gbuffer, fog,                 -> out (or linear, blur separate; over a held
               gbuffer.out_base                 fog, from inputs held with it; a turning
                                                drag's preview: an earlier one's frame
                                                warped, composited where it did not see)
    blur       linear                        -> out
    output     out                           -> image, and a preview drawn whole:
                                                gbuffer.out_base
"""

from __future__ import annotations

from fogbank.render.passes.base import FRAME_INPUTS, Pass
from fogbank.render.passes.blur import BlurPass
from fogbank.render.passes.composite import CompositePass
from fogbank.render.passes.fog import FogPass
from fogbank.render.passes.fog_filter import FogFilterPass
from fogbank.render.passes.light import LightPass
from fogbank.render.passes.output import OutputPass
from fogbank.render.passes.particles import ParticlesPass
from fogbank.render.passes.resolve import ResolvePass
from fogbank.render.passes.scene import ScenePass
from fogbank.render.passes.shadow import ShadowPass
from fogbank.render.passes.sky import SkyPass

FRAME_PASSES: tuple[Pass, ...] = (
    ShadowPass(), ScenePass(), SkyPass(), ResolvePass(), LightPass(), FogPass(), FogFilterPass(), ParticlesPass(), CompositePass(),
    BlurPass(), OutputPass(),
)

__all__ = ["FRAME_INPUTS", "FRAME_PASSES", "BlurPass", "CompositePass", "FogFilterPass", "FogPass", "LightPass",
           "OutputPass", "ParticlesPass", "Pass", "ResolvePass", "ScenePass", "ShadowPass", "SkyPass"]

"""fogbank: analytic fog rendered on the server.

The package shows the pipeline (docs/design.md has the map):
model (a look) -> kinds (fog layer kinds) -> scene -> render (passes) -> stream / service,
with workers (render processes) and tools (bench, soak) beside them.
"""

from pathlib import Path

__version__ = "0.1.0"

PACKAGE_DIR = Path(__file__).resolve().parent
# GLSL ships inside the package (package data), so a wheel install finds it:
# render/shaders holds the passes and shared code, kinds/ one file per fog kind.
SHADER_DIR = PACKAGE_DIR / "render" / "shaders"
KINDS_DIR = PACKAGE_DIR / "kinds"
STATIC_DIR = PACKAGE_DIR / "static"

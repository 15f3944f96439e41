"""fogbank: analytic fog rendered on the server."""

from pathlib import Path

__version__ = "0.1.0"

# The repository root holds shaders/ and static/ next to server/.
ROOT = Path(__file__).resolve().parents[2]
SHADER_DIR = ROOT / "shaders"
STATIC_DIR = ROOT / "static"

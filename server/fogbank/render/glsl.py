"""Loads GLSL (render/shaders/, and kinds/ for the fog kinds) with `#include "path"`, `#line` and errors that name file and line.

Each included file becomes its own GLSL source-string number, so a compiler message such
as `2:14(7): error: ...` is mapped back to `fog/height.glsl:14`. A file is included once
per program (include guards are implicit).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from fogbank import KINDS_DIR, SHADER_DIR

GLSL_VERSION = "#version 330 core"
GLSL_SUFFIXES = {".glsl", ".vert", ".frag"}
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')
# Mesa: "0:12(3): error: ..."; NVIDIA: "0(12) : error C1008: ..."; AMD/ANGLE: "ERROR: 0:12: ..."
_MESSAGE = re.compile(r"(?<![\w.])(\d+)(?::(\d+)\(\d+\)|\((\d+)\)|:(\d+))")


class ShaderError(RuntimeError):
    """A shader failed to load or compile; the message names the file and line."""


@dataclass
class Source:
    text: str
    files: list[str] = field(default_factory=list)  # source-string number -> file name

    def explain(self, message: str) -> str:
        """Rewrite `N:LINE` references in a compiler log to `file:LINE`."""
        def repl(m: re.Match) -> str:
            n = int(m.group(1))
            line = m.group(2) or m.group(3) or m.group(4)
            if n < len(self.files):
                return f"{self.files[n]}:{line}"
            return m.group(0)
        return _MESSAGE.sub(repl, message)


def _resolve(rel: str, root: Path, kinds: Path) -> tuple[Path, Path]:
    """Where an include name lives: `kinds/x.glsl` beside the kind's Python module
    (fogbank/kinds/), anything else under render/shaders/."""
    if rel.startswith("kinds/"):
        return kinds, kinds / rel[len("kinds/"):]
    return root, root / rel


def load(name: str, defines: dict[str, object] | None = None, root: Path = SHADER_DIR,
         generated: dict[str, str] | None = None, kinds: Path = KINDS_DIR) -> Source:
    """Read render/shaders/<name>, expanding includes, with `#define`s placed after #version.

    `generated` maps include names to text made by the server (e.g. the fog layer calls
    for one layer configuration); they are looked up before files."""
    generated = generated or {}
    src = Source("")
    out: list[str] = [GLSL_VERSION]
    for k, v in (defines or {}).items():
        out.append(f"#define {k} {v}")
    seen: set[str] = set()

    def expand(rel: str, chain: tuple[str, ...]) -> None:
        if rel in chain:
            raise ShaderError(f"{' -> '.join(chain + (rel,))}: #include cycle")
        if rel in seen:
            return
        seen.add(rel)
        if rel in generated:
            text = generated[rel]
        else:
            base, path = _resolve(rel, root, kinds)
            path = path.resolve()
            if base.resolve() not in path.parents or not path.is_file() or path.suffix not in GLSL_SUFFIXES:
                where = f"{chain[-1]}: " if chain else ""
                raise ShaderError(f"{where}cannot include {rel!r}: no such shader file")
            text = path.read_text()
        number = len(src.files)
        src.files.append(rel)
        out.append(f"#line 1 {number}")
        for i, line in enumerate(text.splitlines(), start=1):
            m = _INCLUDE.match(line)
            if m:
                expand(m.group(1), chain + (rel,))
                out.append(f"#line {i + 1} {number}")
            elif line.strip().startswith("#version"):
                out.append("")  # the loader owns #version
            else:
                out.append(line)

    expand(name, ())
    src.text = "\n".join(out) + "\n"
    return src


def program(ctx, vertex: str, fragment: str, defines: dict[str, object] | None = None,
            generated: dict[str, str] | None = None, root: Path = SHADER_DIR):
    """Compile and link a program; a failure raises ShaderError naming file and line."""
    vs = load(vertex, defines, root=root, generated=generated)
    fs = load(fragment, defines, root=root, generated=generated)
    try:
        prog = ctx.program(vertex_shader=vs.text, fragment_shader=fs.text)
    except Exception as exc:  # moderngl raises a plain Error with the driver's log
        msg = str(exc)
        stage = fragment if "fragment" in msg.lower() else vertex
        src = fs if stage == fragment else vs
        raise ShaderError(f"{stage}: {src.explain(msg)}") from None
    # what the sources declare, for render/gl.py set_uniform (active uniforms are fewer:
    # the compiler drops the ones a variant does not use)
    prog.extra = {"name": fragment, "declared": declared_uniforms(vs.text, fs.text)}
    return prog


_UNIFORM = re.compile(r"^\s*uniform\s+\w+\s+([^;]+);", re.M)


def declared_uniforms(*sources: str) -> frozenset[str]:
    """The uniform names the GLSL sources declare (`uniform vec3 uFwd, uRight;` too)."""
    names = set()
    for text in sources:
        for decl in _UNIFORM.findall(text):
            for part in decl.split(","):
                names.add(re.split(r"[\s\[]", part.strip(), maxsplit=1)[0])
    return frozenset(names)

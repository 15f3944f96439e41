#!/bin/bash
# fogbank's GPU checks in one call, on a bare GPU machine that has no network and no
# fogbank dependencies (how docs/bench-gpu.md was made). Run from the repo root, with:
#   .gl/    Debian's GL loader packages (libegl1 libglvnd0 libopengl0 libgl1 libglx0
#           libgles2 libvulkan1), unpacked into / here: it refuses to run unless
#           FOGBANK_THROWAWAY=1 is set and nvidia-smi answers (a machine given back after);
#   .whl/   fogbank's Python dependencies as wheels for that machine's Python
#           (`pip download --no-deps --only-binary=:all: --python-version 3.12 ...`:
#           the versions in this checkout's .venv, and opentelemetry-api, which fastapi imports);
#   .old/server   an earlier checkout's server folder (the bench's 'before' server);
#   OUT     a folder for the results: info.txt, gpu_presets.npz (compare with
#           `scripts/preset_stills.py compare`), bench/, bench.log, child.log (the ends of
#           the bench's server logs), gl.log.
# docs/bench-gpu.md came from two calls: the first made the stills (its bench failed), the
# second ran with SKIP_PRESETS=1 BENCH_S=330 GL_S=100.
# BENCH_S and GL_S bound the bench and the GL tests in seconds; SKIP_PRESETS=1 skips the stills.
set -u
source scripts/gpu_env.sh
{ nvidia-smi -L; nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.mem --format=csv; nproc; python3 --version;
  python3 -c "import numpy, PIL; print('numpy', numpy.__version__, 'pillow', PIL.__version__)"; } 2>&1 | tee $OUT/info.txt
stamp probe
python3 -c "from fogbank.render.renderer import create_context, Renderer; print(Renderer(create_context()).info())" 2>&1 | tail -6 | tee -a $OUT/info.txt
if ! grep -q "'renderer':" "$OUT/info.txt"; then
  ls -la /usr/local/nvidia /usr/local/nvidia/lib64 2>&1 | head -40; ls /usr/share/glvnd/egl_vendor.d /usr/local/nvidia/share/glvnd/egl_vendor.d 2>&1
  ldconfig -p | grep -iE "egl|libGL|OpenGL|nvidia" | head -30; exit 4
fi
python3 -c "import fogbank.service.api" || exit 5
stamp "preset stills"   # the same stills as llvmpipe's, to compare pixel by pixel
[ -n "${SKIP_PRESETS:-}" ] || timeout 90 python3 scripts/preset_stills.py save $OUT/gpu_presets.npz 2>&1 | tail -3
stamp "bench --quick"
timeout ${BENCH_S:-360} python3 -m fogbank.cli bench --quick --before-tree .old/server --out $OUT/bench > $OUT/bench.log 2>&1
echo "bench rc $?"; tail -n 40 /tmp/fogbank-child-*.log > $OUT/child.log 2>&1; grep -vE "^\s+round" $OUT/bench.log | tail -60
stamp "gl tests"
timeout ${GL_S:-140} python3 -m pytest tests/gl/test_accuracy.py tests/gl/test_rays.py tests/gl/test_bench.py -m gl -q -p no:cacheprovider --timeout 60 -o addopts="" > $OUT/gl.log 2>&1
echo "gl rc $?"; tail -25 $OUT/gl.log
stamp done

# Sourced by scripts/gpu_check.sh and scripts/gpu_profile.sh on a bare GPU machine: checks
# FOGBANK_THROWAWAY, OUT, .gl/ and .whl/ (see gpu_check.sh), unpacks Debian's GL loaders
# into /, installs the wheels into /tmp/site, and points glcontext and glvnd at the
# loaders and NVIDIA's EGL vendor file. Defines stamp (seconds since it was sourced).
[ "${FOGBANK_THROWAWAY:-}" = 1 ] && nvidia-smi -L >/dev/null 2>&1 || {
  echo "this unpacks GL libraries into /: set FOGBANK_THROWAWAY=1 on a throwaway GPU machine"; exit 2; }
[ -n "${OUT:-}" ] && [ -d "$OUT" ] || { echo "OUT must name an existing folder for the results"; exit 2; }
ls .gl/*.deb >/dev/null 2>&1 && ls .whl/*.whl >/dev/null 2>&1 || { echo "no .gl/*.deb or .whl/*.whl here"; exit 2; }
export PYTHONUNBUFFERED=1
T0=$(date +%s)
stamp(){ echo "== $(( $(date +%s)-T0 )) s: $*"; }
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || { echo "pip failed"; exit 3; }
export PYTHONPATH=/tmp/site:$PWD/server
export GLCONTEXT_LINUX_LIBGL=libOpenGL.so.0 GLCONTEXT_LINUX_LIBEGL=libEGL.so.1
V=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f $V ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$V

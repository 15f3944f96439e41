#!/bin/bash
# A short GPU call (docs/bench-gpu.md, "A later session's calls"): where a 720p stream frame goes
# (scripts/frame_profile.py), a worker's frames and their page faults (scripts/worker_frames.py),
# the sun dragged at 960x540 on this checkout's server and on
# BEFORE's (scripts/sun_drag.py), and, if GL_S is set, the GL tier on the NVIDIA driver.
# Run from the repo root on a bare GPU machine with .gl/ and .whl/ as scripts/gpu_check.sh
# describes, FOGBANK_THROWAWAY=1 (it unpacks GL loaders into /), OUT and BEFORE set.
set -u
source scripts/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version,clocks.sm --format=csv; nproc
stamp "frame profile"
timeout 90 python3 scripts/frame_profile.py > $OUT/profile.txt 2>&1; echo "rc $?"
grep -E "^(held|orbit):|renderer|960x540" $OUT/profile.txt
stamp "worker frames"
timeout 90 python3 scripts/worker_frames.py 2>&1 | tee $OUT/worker_frames.txt
stamp "sun drag"
REPS=${REPS:-2} timeout 150 python3 scripts/sun_drag.py ${BEFORE:-} 2>&1 | grep -vE "^\s*$" | tee $OUT/sun_drag.txt
if [ -n "${GL_S:-}" ]; then
  stamp "gl tier"
  timeout $GL_S python3 -m pytest tests/gl -m gl -q -p no:cacheprovider --timeout 60 -o addopts="-ra" > $OUT/gl.log 2>&1
  echo "gl rc $?"; grep -E "passed|failed|FAILED|ERROR" $OUT/gl.log | tail -25
fi
stamp done

#!/usr/bin/env bash
# Installs the Debian packages fogbank needs (Mesa's EGL, for headless OpenGL) when they
# are missing. As root it runs apt-get; otherwise it prints the command and fails.
set -euo pipefail
PKGS=(libegl1 libegl-mesa0 libgbm1 libgl1-mesa-dri libgl1 libglx-mesa0)
[ "${1:-}" = "--test" ] && PKGS+=(chromium nginx)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -ne 0 ]; then
  echo "fogbank needs these Debian packages: ${missing[*]}" >&2
  echo "run: sudo apt-get install -y --no-install-recommends ${missing[*]}" >&2
  exit 1
fi
echo "installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"

#!/usr/bin/env bash
# setup.sh — installs the Debian packages splatgi needs (clang and
# libclang-rt-dev for the fuzzers of scripts/fuzz.sh; Open MPI for the
# distributed bake, docs/mpi.md, optional at build time) and creates
# assets/bunny.ply. Idempotent: packages already present are skipped by
# apt-get, and an existing asset is left alone.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

packages=(
  build-essential cmake pkg-config libcmocka-dev libpng-dev zlib1g-dev
  libopenexr-dev libomp-dev libembree-dev libcjson-dev libglfw3-dev
  libopencolorio-dev libstb-dev gnuplot-nox xvfb xauth libgl-dev blender-data
  clang libclang-rt-dev
  libopenmpi-dev openmpi-bin
)
# node and npm only convert the bunny. A nodejs from another source (e.g.
# NodeSource) bundles npm and conflicts with Debian's npm package, so ask for
# them only when the commands are absent.
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  sudo_cmd=(sudo)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update
  "${sudo_cmd[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
else
  echo "setup: all packages present"
fi

# The default scene's model: the Stanford bunny from npm (bunny@1.0.1),
# converted to an ASCII PLY.
asset="$root/assets/bunny.ply"
if [ ! -s "$asset" ]; then
  mkdir -p "$root/assets"
  tmp="$(mktemp -d)"
  trap 'rm -rf "$tmp"' EXIT
  (cd "$tmp" && npm pack --silent bunny@1.0.1 >/dev/null)
  tar -xzf "$tmp/bunny-1.0.1.tgz" -C "$tmp"
  node "$root/scripts/bunny_to_ply.js" "$tmp/package" "$asset"
else
  echo "setup: $asset present"
fi

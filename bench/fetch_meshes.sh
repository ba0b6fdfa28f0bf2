#!/usr/bin/env bash
# Fetches the real meshes the benchmarks use into bench/data/ (git-ignored): Debian's libcgal-demo
# (bunny00, refined_elephant, fandisk, ...) and subdivided bunnies of ~1.2M and ~4.8M faces made with
# `meshcvt subdivide`. Idempotent. Usage: bench/fetch_meshes.sh [path/to/meshcvt]
set -euo pipefail
cd "$(dirname "$0")/.."
meshcvt=${1:-build/meshcvt}
mkdir -p bench/data
if [ ! -f bench/data/meshes/bunny00.off ]; then
  tmp=$(mktemp -d)
  (cd "$tmp" && apt-get download libcgal-demo >/dev/null && dpkg -x libcgal-demo_*.deb x)
  tar xzf "$tmp"/x/usr/share/doc/libcgal-dev/data.tar.gz -C "$tmp" data/meshes
  mv "$tmp"/data/meshes bench/data/meshes
  rm -rf "$tmp"
fi
[ -f bench/data/bunny-1.2M.ply ] || "$meshcvt" subdivide bench/data/meshes/bunny00.off -k 2 -o bench/data/bunny-1.2M.ply
[ -f bench/data/bunny-4.8M.ply ] || "$meshcvt" subdivide bench/data/meshes/bunny00.off -k 3 -o bench/data/bunny-4.8M.ply

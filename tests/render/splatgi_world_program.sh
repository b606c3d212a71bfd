#!/bin/sh
# splatgi_world_program.sh — the world file end to end on a small scene
# of four surfaces (MLS, disk, ISO, hybrid): splatgi-world writes it; a bake and a
# frame made with --world are the same bytes (cmp) as those made by
# building; --if-stale keeps a fresh file and rebuilds a damaged or stale
# one; --world refuses a missing, damaged or other scene's file and a bake
# file, and --if-stale never writes a world over a file that is not one.
# usage: splatgi_world_program.sh SPLATGI_WORLD SPLATGI_BAKE SPLATGI_RENDER WORKDIR
set -u
WORLD=$1 BAKE=$2 RENDER=$3 DIR=$4
rm -rf "$DIR" && mkdir -p "$DIR" || exit 1
cd "$DIR" || exit 1
fail() { echo "FAIL: $*" >&2; exit 1; }

cat > scene.json <<'JSON'
{ "models": [ { "builtin": "sphere", "points": 6000, "transform": { "translate": [0, 1, 0] },
                "material": { "type": "ggx", "roughness": 0.4 } },
              { "builtin": "ground", "points": 4000, "surface": { "model": "disk" } },
              { "builtin": "sphere", "points": 3000, "transform": { "translate": [2.2, 1, 0] },
                "surface": { "model": "iso" } },
              { "builtin": "sphere", "points": 2000, "transform": { "translate": [-1.2, 0.6, 1.5], "scale": 0.5 },
                "surface": { "model": "hybrid" } } ],
  "envmap": { "builtin": "sky" },
  "cameras": [ { "name": "main", "eye": [1, 2.5, 5], "look": [1, 0.8, 0] } ],
  "render": { "width": 96, "height": 96 } }
JSON
sed 's/"points": 6000/"points": 5000/' scene.json > other.json

# 1. The world file, then bakes and frames from it and from a build: cmp.
"$WORLD" scene.json -o w.sgworld > w.log 2>&1 || { cat w.log; fail "splatgi-world"; }
grep -q "wrote w.sgworld" w.log || { cat w.log; fail "no report"; }
"$WORLD" scene.json -o w.sgworld --if-stale > s.log 2>&1 || { cat s.log; fail "--if-stale"; }
grep -q "w.sgworld is up to date" s.log || { cat s.log; fail "a fresh world was not kept"; }
BOPT="--direct 8 --gather-rays 16 --threads 2"
"$BAKE" scene.json -o built.sgbake $BOPT > b1.log 2>&1 || { cat b1.log; fail "bake (built)"; }
"$BAKE" scene.json -o loaded.sgbake $BOPT --world w.sgworld > b2.log 2>&1 || { cat b2.log; fail "bake (--world)"; }
grep -q "world loaded from w.sgworld" b2.log || { cat b2.log; fail "the bake did not load the world"; }
cmp built.sgbake loaded.sgbake || fail "bakes differ"
"$RENDER" scene.json --bake built.sgbake --out built.exr > r1.log 2>&1 || { cat r1.log; fail "render (built)"; }
"$RENDER" scene.json --bake built.sgbake --world w.sgworld --out loaded.exr > r2.log 2>&1 || { cat r2.log; fail "render (--world)"; }
cmp built.exr loaded.exr || fail "frames differ"

# 2. Refusals, each naming the fault.
"$RENDER" scene.json --bake built.sgbake --world none.sgworld --out x.exr > e1.log 2>&1 && fail "missing world accepted"
grep -q "none.sgworld: No such file" e1.log || { cat e1.log; fail "message (missing)"; }
"$WORLD" other.json -o w.sgworld --check > e2.log 2>&1 && fail "other scene accepted"
grep -q "w.sgworld: made for another scene" e2.log || { cat e2.log; fail "message (other scene)"; }
"$RENDER" scene.json --bake built.sgbake --world built.sgbake --out x.exr > e3.log 2>&1 && fail "bake accepted as world"
grep -q "a splatgi bake file, not a world file" e3.log || { cat e3.log; fail "message (bake)"; }
"$RENDER" scene.json --bake built.sgbake --world built.sgbake --if-stale --out x.exr > e4.log 2>&1 && fail "bake replaced"
grep -q "not a world file; it is left alone" e4.log || { cat e4.log; fail "message (replace bake)"; }
cmp built.sgbake loaded.sgbake || fail "the bake was touched"
cp w.sgworld d.sgworld
size=$(wc -c < d.sgworld)
printf '\377' | dd of=d.sgworld bs=1 seek=$((size / 2)) conv=notrunc 2>/dev/null
"$RENDER" scene.json --bake built.sgbake --world d.sgworld --out x.exr > e5.log 2>&1 && fail "damaged world accepted"
grep -q "d.sgworld: section .*: checksum mismatch" e5.log || { cat e5.log; fail "message (damaged)"; }
"$RENDER" scene.json --bake built.sgbake --if-stale --out x.exr > e6.log 2>&1 && fail "--if-stale alone accepted"
grep -q "\-\-if-stale goes with --world" e6.log || { cat e6.log; fail "message (--if-stale alone)"; }

# 3. --if-stale rebuilds the damaged file, and the result is the good one.
"$RENDER" scene.json --bake built.sgbake --world d.sgworld --if-stale --out y.exr > e7.log 2>&1 || { cat e7.log; fail "--if-stale rebuild"; }
grep -q "building the world again" e7.log || { cat e7.log; fail "no rebuild said"; }
cmp built.exr y.exr || fail "frame after rebuild differs"
cmp w.sgworld d.sgworld || fail "the rebuilt world differs from the first"
# ... and makes a missing one, the same bytes again (a world file is a
# function of its scene).
"$RENDER" scene.json --bake built.sgbake --world n.sgworld --if-stale --out z.exr > e8.log 2>&1 || { cat e8.log; fail "--if-stale, missing"; }
cmp w.sgworld n.sgworld || fail "the world made by --if-stale differs from splatgi-world's"
cmp built.exr z.exr || fail "frame with a new world differs"
echo "ok"

"""Renders an exported Mitsuba 3 scene with the LLVM backend and times it (driver for bench_render).

    python mitsuba_render.py SCENE.xml --spp 16 64 --reps 3 --out-dir DIR

For each spp: the first render in the process is timed as "cold" (it traces the kernel and pays the JIT
compile, or loads it from drjit's on-disk kernel cache), then `reps` further renders are timed as "warm"
and the best is kept. Only mi.render (plus the wait for its result) is timed, not scene loading.
Writes DIR/mitsuba_<spp>spp.exr (the last render) and prints one JSON object per spp on stdout.
Needs benchmarks/setup_mitsuba.sh (venv, libllvm19, DRJIT_LIBLLVM_PATH).
"""

import argparse
import json
import os
import time

import drjit as dr
import mitsuba as mi


def timed_render(scene, spp, seed):
    t = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - t, img


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--spp", type=int, nargs="+", required=True)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    a = ap.parse_args()
    mi.set_variant(a.variant)
    scene = mi.load_file(a.scene)
    os.makedirs(a.out_dir, exist_ok=True)
    for spp in a.spp:
        cold, img = timed_render(scene, spp, a.seed)
        warm = [timed_render(scene, spp, a.seed + 1 + r)[0] for r in range(a.reps)]
        path = os.path.join(a.out_dir, f"mitsuba_{spp}spp.exr")
        mi.Bitmap(img).write(path)
        print(json.dumps({"spp": spp, "cold_s": cold, "warm_s": min(warm, default=None), "image": path}), flush=True)


if __name__ == "__main__":
    main()

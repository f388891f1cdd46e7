"""Forward+backward iterations of Mitsuba 3 (LLVM) on an exported psdr scene: timing and gradients (driver for
bench_grad; run by it, one process per scene).

    python mitsuba_grad.py CONFIG.json

CONFIG (written by bench_grad):
    scene        exported scene.xml (`psdr export --format mitsuba`)
    width/height image size (must match the film; checked)
    target       raw little-endian float32 file, height x width x 3, rows from the top (psdr's Frame layout)
    reference    optional: our unperturbed render at high spp, same layout (primal agreement check)
    reference_spp  spp of Mitsuba's primal render for that check
    max_depth, rr_depth
    params       list of {"label", "kind": "translation", "shapes": [ids], "component": c}
                 or {"label", "kind": "value", "keys": [keys of mi.traverse(scene)]}
    integrators  list of {"label", "type", "spp": [samples per pixel], ...extra plugin properties}
                 e.g. {"label": "prb_projective_noguide", "type": "prb_projective", "guiding": "none", "spp": [16]}
                 and optionally its own "seeds" (e.g. fewer for slow integrators) and "weld": true (render a
                 copy of the scene whose PLY meshes have their vertices merged by position, see welded_scene)
    seeds        list of seeds (one timed iteration each)
    interleave   optional true: before each timed iteration print {"event": "ready", "remaining": n} and wait
                 for a line on stdin, so the caller can run its own iterations in between (both methods then
                 see the same drift of the machine)
    fd           optional {"spp", "seeds": [..], "steps": {label: h}}: central differences of Mitsuba's own L2
                 loss (path tracer, same seed at +h and -h), a check of the parameter hookup and of how far
                 Mitsuba's gradient is from Mitsuba's own truth

One iteration = set the differentiable parameters (a translation applied to the shapes' vertex positions, or a
fresh copy of the RGB value with gradients enabled) + params.update() + mi.render(scene, params, spp, seed)
+ L2 loss (mean over pixels and channels of the squared difference to the target, as psdr's L2To) +
dr.backward + reading the gradient. Per (integrator, spp) the first iteration is a warm-up, timed and reported
as "cold" (JIT compile, or drjit's on-disk kernel cache); then one timed iteration per seed. Kernels do not
depend on spp, so later spp values of the same integrator reuse them (the first seed's time would show it).
Prints one JSON object per line on stdout. Needs benchmarks/setup_mitsuba.sh (venv, DRJIT_LIBLLVM_PATH).
"""

import json
import os
import sys
import time
import xml.etree.ElementTree as ET

import drjit as dr
import mitsuba as mi
import numpy as np


def load_image(path, w, h):
    a = np.fromfile(path, dtype="<f4")
    assert a.size == w * h * 3, f"{path}: {a.size} floats, expected {w * h * 3}"
    return a.reshape(h, w, 3)


def load_scene(xml_path, shape_ids):
    """Loads with Mitsuba's optimisations (merging meshes), unless that merges away a shape the parameters move
    (Mitsuba 3.9 merges the parts of a furniture model into one mesh without an id): then without them."""
    scene = mi.load_file(xml_path)
    keys = mi.traverse(scene).keys()
    if all(f"{sid}.vertex_positions" in keys for sid in shape_ids):
        return scene
    return mi.load_file(xml_path, optimize=False)


def welded_scene(xml_path, shape_ids):
    """The scene with every PLY mesh's vertices merged by position (same triangles, same winding; the export
    keeps face_normals, so shading is unchanged). psdr's box primitive and OBJ faces export with per-face vertex
    copies; Mitsuba then sees every triangle edge as an open boundary (perimeter) edge, which its projective
    integrators sample as a discontinuity on its own, so an edge shared by two faces is counted twice."""
    d = os.path.dirname(os.path.abspath(xml_path))
    tree = ET.parse(xml_path)
    for sh in tree.getroot().findall("shape"):
        fn = sh.find("string[@name='filename']")
        if sh.get("type") != "ply" or fn is None:
            continue
        m = mi.load_dict({"type": "ply", "filename": os.path.join(d, fn.get("value")), "face_normals": True})
        mp = mi.traverse(m)
        v = np.array(mp["vertex_positions"], dtype=np.float64).reshape(-1, 3)
        f = np.array(mp["faces"], dtype=np.int64).reshape(-1, 3)
        uniq, inv = np.unique(np.round(v, 5), axis=0, return_inverse=True)
        f2 = inv.reshape(-1)[f]
        mesh = mi.Mesh(sh.get("id"), len(uniq), len(f2), has_vertex_normals=False, has_vertex_texcoords=False)
        wp = mi.traverse(mesh)
        wp["vertex_positions"] = mi.Float(uniq.astype(np.float32).reshape(-1))
        wp["faces"] = mi.UInt32(f2.astype(np.uint32).reshape(-1))
        wp.update()
        rel = f"meshes/{sh.get('id')}_welded.ply"
        mesh.write_ply(os.path.join(d, rel))
        fn.set("value", rel)
    out = os.path.join(d, "scene_welded.xml")
    tree.write(out)
    return load_scene(out, shape_ids)


class Params:
    """The differentiable parameters of one iteration, built fresh each time (backward consumes the graph)."""

    def __init__(self, scene, specs):
        self.params = mi.traverse(scene)
        self.specs = specs
        self.initial = {}
        for p in specs:
            if p["kind"] == "translation":
                for sid in p["shapes"]:
                    k = f"{sid}.vertex_positions"
                    self.initial[k] = dr.unravel(mi.Point3f, mi.Float(self.params[k]))
            else:
                for k in p["keys"]:
                    self.initial[k] = type(self.params[k])(self.params[k])

    def set_offset(self, spec, comp, delta):
        """Sets one parameter component to its initial value + delta, without gradients."""
        if spec["kind"] == "translation":
            offset = [0.0, 0.0, 0.0]
            offset[spec["component"]] = delta
            for sid in spec["shapes"]:
                k = f"{sid}.vertex_positions"
                self.params[k] = dr.ravel(self.initial[k] + mi.Vector3f(*offset))
        else:
            for k in spec["keys"]:
                v = np.array(self.initial[k], dtype=np.float32).reshape(-1)
                v[comp] += delta
                self.params[k] = type(self.initial[k])(*v.tolist())
        self.params.update()

    def attach(self):
        """Sets the parameters from fresh differentiable variables; returns them by label."""
        handles = {}
        for p in self.specs:
            if p["kind"] == "translation":
                t = mi.Float(0.0)
                dr.enable_grad(t)
                offset = [mi.Float(0.0), mi.Float(0.0), mi.Float(0.0)]
                offset[p["component"]] = t
                for sid in p["shapes"]:
                    k = f"{sid}.vertex_positions"
                    self.params[k] = dr.ravel(self.initial[k] + mi.Vector3f(*offset))
                handles[p["label"]] = [t]
            else:
                vs = []
                for k in p["keys"]:
                    v = type(self.initial[k])(self.initial[k])
                    dr.enable_grad(v)
                    self.params[k] = v
                    vs.append(v)
                handles[p["label"]] = vs
        self.params.update()
        return handles


def gradient_of(handles):
    """Per label: the gradient as a flat list (translation: one float; RGB values: 3, summed over keys)."""
    out = {}
    for label, vs in handles.items():
        g = None
        for v in vs:
            gv = np.array(dr.grad(v), dtype=np.float64).reshape(-1)
            g = gv if g is None else g + gv
        out[label] = g.tolist()
    return out


def iteration(scene, state, integrator, target, spp, seed):
    t0 = time.perf_counter()
    handles = state.attach()
    img = mi.render(scene, state.params, integrator=integrator, spp=spp, seed=seed)
    loss = dr.mean(dr.square(img - target), axis=None)
    dr.backward(loss)
    grads = gradient_of(handles)
    dr.sync_thread()
    secs = time.perf_counter() - t0
    return secs, float(loss.array[0]), grads


def main():
    cfg = json.load(open(sys.argv[1]))
    mi.set_variant("llvm_ad_rgb")
    w, h = cfg["width"], cfg["height"]
    t = time.perf_counter()
    shape_ids = [sid for p in cfg["params"] if p["kind"] == "translation" for sid in p["shapes"]]
    scene = load_scene(cfg["scene"], shape_ids)
    load_s = time.perf_counter() - t
    film = scene.sensors()[0].film()
    assert list(film.size()) == [w, h], f"film {list(film.size())} != {[w, h]}"
    target_np = load_image(cfg["target"], w, h)
    target = mi.TensorXf(target_np)
    print(json.dumps({"event": "loaded", "load_s": load_s, "mitsuba": mi.__version__, "drjit": dr.__version__}),
          flush=True)

    if cfg.get("reference"):
        # Primal agreement and orientation: Mitsuba's path tracer against our high-spp render of the same scene.
        ours = load_image(cfg["reference"], w, h).astype(np.float64)
        path = mi.load_dict({"type": "path", "max_depth": cfg["max_depth"], "rr_depth": cfg["rr_depth"]})
        t = time.perf_counter()
        img = np.array(mi.render(scene, integrator=path, spp=cfg["reference_spp"], seed=12345), dtype=np.float64)
        primal_s = time.perf_counter() - t

        def rel_l1(a, b):
            return float(np.abs(a - b).mean() / np.abs(b).mean())

        print(json.dumps({
            "event": "primal_check",
            "spp": cfg["reference_spp"],
            "seconds": primal_s,
            "mean_rgb_mitsuba": img.reshape(-1, 3).mean(0).tolist(),
            "mean_rgb_ours": ours.reshape(-1, 3).mean(0).tolist(),
            "rel_mean_diff": float(abs(img.mean() - ours.mean()) / ours.mean()),
            "rel_l1": rel_l1(img, ours),
            "rel_l1_flip_x": rel_l1(img[:, ::-1], ours),
            "rel_l1_flip_y": rel_l1(img[::-1], ours),
        }), flush=True)

    state = Params(scene, cfg["params"])
    welded = None
    if cfg.get("fd"):
        fd = cfg["fd"]
        path = mi.load_dict({"type": "path", "max_depth": cfg["max_depth"], "rr_depth": cfg["rr_depth"]})

        def loss_at(spec, comp, delta, seed):
            state.set_offset(spec, comp, delta)
            img = mi.render(scene, integrator=path, spp=fd["spp"], seed=seed)
            return float(dr.mean(dr.square(img - target), axis=None).array[0])

        for spec in cfg["params"]:
            h = fd["steps"][spec["label"]]
            comps = [0] if spec["kind"] == "translation" else [0, 1, 2]
            t = time.perf_counter()
            per_seed = [[(loss_at(spec, c, h, s) - loss_at(spec, c, -h, s)) / (2 * h) for c in comps]
                        for s in fd["seeds"]]
            state.set_offset(spec, 0, 0.0)
            a = np.array(per_seed)
            print(json.dumps({"event": "fd", "label": spec["label"], "spp": fd["spp"], "seconds": time.perf_counter() - t,
                              "mean": a.mean(0).tolist(),
                              "std_err": (a.std(0, ddof=1) / np.sqrt(len(a))).tolist() if len(a) > 1 else None}),
                  flush=True)
    remaining = sum(len(spec["spp"]) * len(spec.get("seeds", cfg["seeds"])) for spec in cfg["integrators"])
    for spec in cfg["integrators"]:
        name = spec["label"]
        props = {k: v for k, v in spec.items() if k not in ("label", "spp", "seeds", "weld")}
        sc, st = scene, state
        if spec.get("weld"):
            if welded is None:
                w_scene = welded_scene(cfg["scene"], shape_ids)
                welded = (w_scene, Params(w_scene, cfg["params"]))
            sc, st = welded
        integrator = mi.load_dict({"max_depth": cfg["max_depth"], "rr_depth": cfg["rr_depth"], **props})
        for i, spp in enumerate(spec["spp"]):
            if i == 0:
                cold, loss, grads = iteration(sc, st, integrator, target, spp, 1_000_003)
                print(json.dumps({"event": "cold", "integrator": name, "spp": spp, "seconds": cold, "loss": loss,
                                  "grad": grads}), flush=True)
            for seed in spec.get("seeds", cfg["seeds"]):
                if cfg.get("interleave"):
                    print(json.dumps({"event": "ready", "remaining": remaining}), flush=True)
                    sys.stdin.readline()
                    remaining -= 1
                secs, loss, grads = iteration(sc, st, integrator, target, spp, seed)
                print(json.dumps({"event": "iteration", "integrator": name, "spp": spp, "seed": seed,
                                  "seconds": secs, "loss": loss, "grad": grads}), flush=True)


if __name__ == "__main__":
    main()

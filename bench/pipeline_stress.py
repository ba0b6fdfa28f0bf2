#!/usr/bin/env python3
"""Stress the whole CLI pipeline with damaged meshes: a robustness sweep, not a benchmark.

bench/fuzz/ fuzzes the readers byte by byte; the clustering, the coarsening and the shape
approximation only ever see what a reader accepts, and a fuzzer seldom gets through a reader
with a mesh large enough to cluster. This script starts from real meshes (OFF files), damages them
the way real files are damaged (holes, duplicated or flipped faces, fins on non-manifold edges,
collapsed faces, welded or pinched vertices, stray small components, far offsets, tiny or huge
scales, unreferenced vertices, NaN coordinates) and runs `meshcvt coarsen`, `cluster` and
`approximate` on them with random counts and options.

A run passes when
  * it exits 0 and the outputs it was asked for exist (coarsen: the requested vertex count unless
    it warned of defects, cluster/approximate: a label per face), or
  * it exits 1 or 2 with a `meshcvt: error:` line naming the input file (not an internal error:
    an exception meshcvt does not raise itself) and leaves no output, no temporary file behind;
  * with --gpu-faults, a run given $MESHCVT_GPU_FAULT (a lost device at the N-th wait of the GPU
    engine, or no device memory at its N-th buffer, N random) may also fail with an error line
    that names that VkResult instead of the input, under the same rules about its outputs;
and fails on anything else: a signal, a sanitizer report, a timeout (a hang), a half-written or
missing output, an exit status 0 with an error line. Failing cases are kept in WORK/fail-N/ with the
command line (`cmd.txt`), stderr, and the damaged mesh, so that they can be rerun.

usage: bench/pipeline_stress.py MESHCVT SECONDS [--runs N] [--seed S] [--work DIR] [--timeout T] [--gpu SHARE]
                                [--gpu-faults SHARE] [--light] [--slow S] MESH.off...
       (MESHCVT: best a sanitizer build, e.g. build-asan/meshcvt; T per run, default 120 s)
Prints one line per failure and a summary; exit status 1 when anything failed.
"""
import argparse
import math
import os
import random
import shutil
import struct
import subprocess
import sys
import time


def read_off(path):
    """A plain OFF reader for the seeds, line by line (extra values on a line, as colours, are
    ignored; polygons are fan-split)."""
    with open(path) as f:
        lines = [l.split("#", 1)[0].split() for l in f]
    lines = [l for l in lines if l]
    if not lines[0][0].endswith("OFF"):
        raise ValueError(path + ": not an OFF file")
    counts = lines[0][1:] if len(lines[0]) > 1 else lines[1]
    body = lines[1:] if len(lines[0]) > 1 else lines[2:]
    nv, nf = int(counts[0]), int(counts[1])
    verts = [[float(x) for x in l[:3]] for l in body[:nv]]
    faces = []
    for l in body[nv:nv + nf]:
        k = int(l[0])
        poly = [int(w) for w in l[1:1 + k]]
        for j in range(1, k - 1):
            faces.append([poly[0], poly[j], poly[j + 1]])
    return verts, faces


# ---- damage ------------------------------------------------------------------------------------

def pick(rng, faces, share):
    count = max(1, int(len(faces) * share))
    return rng.sample(range(len(faces)), min(count, len(faces)))


def holes(rng, v, f):
    """Delete a few patches of faces (holes, sometimes cutting components apart)."""
    share = rng.choice([0.001, 0.01, 0.05, 0.2])
    drop = set(pick(rng, f, share))
    return v, [t for i, t in enumerate(f) if i not in drop], "holes %g" % share


def duplicate_faces(rng, v, f):
    extra = [list(f[i]) if rng.random() < 0.5 else list(reversed(f[i])) for i in pick(rng, f, rng.choice([0.001, 0.02]))]
    return v, f + extra, "duplicate %d faces" % len(extra)


def flip_faces(rng, v, f):
    share = rng.choice([0.01, 0.5])
    flip = set(pick(rng, f, share))
    return v, [list(reversed(t)) if i in flip else t for i, t in enumerate(f)], "flip %g" % share


def fins(rng, v, f):
    """A face on an existing edge and a new vertex: an edge of three faces."""
    v = [list(p) for p in v]
    f = list(f)
    count = rng.choice([1, 3, 20])
    for _ in range(count):
        t = rng.choice(f)
        a, b = t[0], t[1]
        pa, pb = v[a], v[b]
        v.append([(pa[k] + pb[k]) / 2 + rng.uniform(-1, 1) * abs(pa[k] - pb[k] + 1e-3) for k in range(3)])
        f.append([a, b, len(v) - 1])
    return v, f, "fins %d" % count


def collapse_faces(rng, v, f):
    chosen = set(pick(rng, f, rng.choice([0.001, 0.05, 1.0])))
    out = [[t[0], t[0], t[2]] if i in chosen else t for i, t in enumerate(f)]
    return v, out, "collapse %d faces" % len(chosen)


def weld_vertices(rng, v, f):
    """Replace vertex a by b in every face: pinches, collapsed faces, non-manifold edges."""
    mapping = {}
    for _ in range(rng.choice([1, 5, 50])):
        a, b = rng.randrange(len(v)), rng.randrange(len(v))
        mapping[a] = b
    return v, [[mapping.get(x, x) for x in t] for t in f], "weld %d vertices" % len(mapping)


def coincide(rng, v, f):
    """Move vertices onto others' positions (zero-area faces, duplicate points)."""
    v = [list(p) for p in v]
    count = rng.choice([1, 10, 100])
    for _ in range(count):
        v[rng.randrange(len(v))] = list(v[rng.randrange(len(v))])
    return v, f, "coincide %d" % count


def small_parts(rng, v, f):
    v = [list(p) for p in v]
    f = list(f)
    count = rng.choice([1, 2, 40])
    for _ in range(count):
        o = len(v)
        c = [rng.uniform(-1, 1) for _ in range(3)]
        s = rng.choice([1e-6, 1e-2, 1.0])
        if rng.random() < 0.5:  # a lone triangle
            v += [c, [c[0] + s, c[1], c[2]], [c[0], c[1] + s, c[2]]]
            f.append([o, o + 1, o + 2])
        else:  # a tetrahedron
            v += [c, [c[0] + s, c[1], c[2]], [c[0], c[1] + s, c[2]], [c[0], c[1], c[2] + s]]
            f += [[o, o + 2, o + 1], [o, o + 1, o + 3], [o, o + 3, o + 2], [o + 1, o + 2, o + 3]]
    return v, f, "small parts %d" % count


def transform(rng, v, f):
    scale = rng.choice([1e-30, 1e-6, 1e6, 1e30])
    shift = rng.choice([0.0, 1e4, 1e7])
    return [[p[k] * scale + shift for k in range(3)] for p in v], f, "scale %g shift %g" % (scale, shift)


def unreferenced(rng, v, f):
    v = [list(p) for p in v] + [[rng.uniform(-9, 9) for _ in range(3)] for _ in range(rng.choice([1, 1000]))]
    return v, f, "unreferenced vertices"


def not_finite(rng, v, f):
    v = [list(p) for p in v]
    v[rng.randrange(len(v))][rng.randrange(3)] = rng.choice([math.nan, math.inf, -math.inf])
    return v, f, "a coordinate not finite"


def strip_faces(rng, v, f):
    """Keep only a small connected-ish piece (the first faces), as a truncated file would."""
    keep = rng.choice([1, 2, 5, 30])
    return v, f[:keep], "first %d faces only" % keep


DAMAGE = [holes, duplicate_faces, flip_faces, fins, collapse_faces, weld_vertices, coincide, small_parts,
          transform, unreferenced, not_finite, strip_faces]


# ---- writers -----------------------------------------------------------------------------------

def fmt(x):
    return repr(float(x)) if math.isfinite(x) else ("nan" if math.isnan(x) else ("inf" if x > 0 else "-inf"))


def write(path, v, f):
    ext = os.path.splitext(path)[1]
    if ext == ".off":
        with open(path, "w") as o:
            o.write("OFF\n%d %d 0\n" % (len(v), len(f)))
            o.writelines("%s %s %s\n" % tuple(fmt(x) for x in p) for p in v)
            o.writelines("3 %d %d %d\n" % tuple(t) for t in f)
    elif ext == ".obj":
        with open(path, "w") as o:
            o.writelines("v %s %s %s\n" % tuple(fmt(x) for x in p) for p in v)
            o.writelines("f %d %d %d\n" % tuple(x + 1 for x in t) for t in f)
    elif ext == ".ply":  # binary little endian
        with open(path, "wb") as o:
            o.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                     "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n"
                     % (len(v), len(f))).encode())
            for p in v:
                o.write(struct.pack("<3f", *[max(-3.4e38, min(3.4e38, x)) if math.isfinite(x) else x for x in p]))
            for t in f:
                o.write(struct.pack("<B3i", 3, *t))
    elif ext == ".stl":  # binary: the corners' positions only (the reader welds them)
        with open(path, "wb") as o:
            o.write(b"meshcvt stress".ljust(80, b" ") + struct.pack("<I", len(f)))
            for t in f:
                pts = []
                for x in t:
                    pts += [max(-3.4e38, min(3.4e38, c)) if math.isfinite(c) else c for c in v[x]]
                o.write(struct.pack("<12fH", 0, 0, 0, *pts, 0))
    else:
        raise ValueError(ext)


# ---- runs --------------------------------------------------------------------------------------

SANITIZER_MARKS = ("ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:", "AddressSanitizer:DEADLYSIGNAL")


def count_vertices(path):
    """Vertices of a written OFF, or None when it cannot be read."""
    try:
        with open(path) as f:
            if f.readline().strip() != "OFF":
                return None
            return int(f.readline().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def count_lines(path):
    try:
        with open(path) as f:
            return sum(1 for _ in f)
    except OSError:
        return None


# What a fault made on demand ($MESHCVT_GPU_FAULT's kind) must name in the error line.
FAULT_RESULTS = {"lost": "VK_ERROR_DEVICE_LOST", "memory": "VK_ERROR_OUT_OF_DEVICE_MEMORY"}


def one_run(rng, meshcvt, seed_mesh, run_dir, timeout, gpu_share=0.0, light=False, fault_share=0.0):
    verts, faces = seed_mesh
    steps = []
    for _ in range(rng.choice([1, 1, 2, 3])):
        if not faces or not verts:
            break
        verts, faces, what = rng.choice(DAMAGE)(rng, verts, faces)
        steps.append(what)
    if not faces:
        faces = [[0, 0, 0]] if verts else []
    ext = rng.choice([".off", ".off", ".obj", ".ply", ".stl"])
    mesh_path = os.path.join(run_dir, "in" + ext)
    write(mesh_path, verts, faces)
    nfaces = max(1, len(faces))
    n = rng.choice([1, 3, 4, 10, max(4, nfaces // 40), max(4, nfaces // 10), max(4, nfaces // 3),
                    nfaces * 2 if not light else max(4, nfaces // 20)])
    command = rng.choice(["coarsen", "coarsen", "coarsen", "cluster", "approximate"])
    out = os.path.join(run_dir, "out.off")
    labels = os.path.join(run_dir, "labels.txt")
    # (Not quiet: the coarsen check below accepts another vertex count only with the warning that
    # defects remain, which -q would hide.)
    args = [meshcvt, command, mesh_path, "-n", str(n), "-o", out]
    if command == "coarsen":
        args += ["--no-error"]
        args += rng.choice([[], ["--vertex", "qem"], ["--vertex", "closest"], ["--gradation", "1"],
                            ["--metric", "ccvt"], ["--subdivide", "0"], ["--split-edges", "0"]])
        if rng.random() < 0.3:
            args += ["--labels", labels]
    elif command == "cluster":
        args += ["--labels", labels] + rng.choice([[], ["--metric", "ccvt"], ["--threads", "1"]])
    else:
        args += rng.choice([[], ["--labels", labels]])
    if gpu_share > 0 and command in ("coarsen", "cluster") and rng.random() < gpu_share:
        args += ["--device", "gpu"]
    if rng.random() < 0.3 and "--threads" not in args:
        args += ["--threads", rng.choice(["1", "2", "3"])]
    env = dict(os.environ)
    env.setdefault("ASAN_OPTIONS", "detect_leaks=1:abort_on_error=1")
    env.setdefault("UBSAN_OPTIONS", "print_stacktrace=1:halt_on_error=1")
    # The Vulkan layer's and lavapipe's own leaks (tests/lsan.supp says which), as the test suite.
    env.setdefault("LSAN_OPTIONS", "suppressions=" + os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                                 "..", "tests", "lsan.supp"))
    fault = None  # (drawn only with --gpu-faults: the runs of a seed stay the same without it)
    command_line = args
    if fault_share > 0 and "--device" in args and rng.random() < fault_share:
        fault = rng.choice(sorted(FAULT_RESULTS))
        env["MESHCVT_GPU_FAULT"] = "%s:%d" % (fault, rng.randint(1, 40))
        command_line = ["MESHCVT_GPU_FAULT=" + env["MESHCVT_GPU_FAULT"]] + args  # as cmd.txt shows it
    try:
        p = subprocess.run(args, capture_output=True, text=True, timeout=timeout, env=env)
        rc, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired as e:
        rc, err = "timeout", (e.stderr or b"").decode(errors="replace") if isinstance(e.stderr, bytes) else (e.stderr or "")
    problem = None
    left = sorted(x for x in os.listdir(run_dir) if x not in ("in" + ext, "out.off", "labels.txt"))
    if rc == "timeout":
        problem = "timeout after %d s" % timeout
    elif any(m in err for m in SANITIZER_MARKS):
        problem = "sanitizer report"
    elif not isinstance(rc, int) or rc < 0 or rc > 2:
        problem = "exit status %s" % rc
    elif left:
        problem = "files left behind: %s" % " ".join(left)
    elif rc == 0:
        if "meshcvt: error" in err:
            problem = "exit 0 with an error line"
        elif command == "coarsen" and count_vertices(out) is None:
            problem = "no readable output"
        elif command == "coarsen" and count_vertices(out) != n and "defects remain" not in err:
            problem = "%s vertices for n = %d without a warning" % (count_vertices(out), n)
        elif "--labels" in args and count_lines(labels) is None:
            problem = "no labels file"
    else:
        error_lines = [l for l in err.splitlines() if l.startswith("meshcvt: error: ")]
        if not error_lines:
            problem = "exit %d without an error line" % rc
        elif any(l.startswith("meshcvt: error: internal:") for l in error_lines):
            problem = "an internal error (an exception meshcvt does not raise itself)"
        elif mesh_path not in error_lines[0] and not (fault and FAULT_RESULTS[fault] in error_lines[0]):
            problem = "the error names neither the input nor %s" % FAULT_RESULTS[fault] if fault else \
                      "the error does not name the input"
        elif os.path.exists(out) or os.path.exists(labels):
            problem = "exit %d but an output was written" % rc
    return problem, command_line, steps, err


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshcvt")
    ap.add_argument("seconds", type=float)
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--work", default="bench/work/stress")
    ap.add_argument("--timeout", type=float, default=120)
    ap.add_argument("--runs", type=int, default=0,
                    help="stop after this many runs (0: run until SECONDS are up); with a fixed --seed the "
                         "runs are the same every time, as a test needs")
    ap.add_argument("--light", action="store_true",
                    help="no count above the faces (those subdivide first: 20-30 s each on the elephant with "
                         "qem, ten times that under ASan), for a test")
    ap.add_argument("--slow", type=float, default=0.0, metavar="S",
                    help="also print the runs that took more than S seconds, kept in WORK/slow-N (not failures; "
                         "0: off)")
    ap.add_argument("--gpu", type=float, default=0.0, metavar="SHARE",
                    help="share of cluster and coarsen runs given --device gpu (default 0)")
    ap.add_argument("--gpu-faults", type=float, default=0.0, metavar="SHARE",
                    help="share of the --device gpu runs given $MESHCVT_GPU_FAULT, a lost device or no device "
                         "memory at a random point (default 0)")
    a = ap.parse_args()
    rng = random.Random(a.seed)
    seeds = [(m, read_off(m)) for m in a.meshes]
    os.makedirs(a.work, exist_ok=True)
    end = time.time() + a.seconds
    runs = failures = slow = 0
    outcomes = {}
    while (a.runs == 0 or runs < a.runs) and (a.runs > 0 or time.time() < end):
        name, mesh = rng.choice(seeds)
        run_dir = os.path.join(a.work, "run")
        shutil.rmtree(run_dir, ignore_errors=True)
        os.makedirs(run_dir)
        started = time.time()
        problem, args, steps, err = one_run(rng, a.meshcvt, mesh, run_dir, a.timeout, a.gpu, a.light, a.gpu_faults)
        took = time.time() - started
        runs += 1
        def keep(kind, number, what):
            """Copies the run to WORK/kind-number with its command and stderr; prints a line."""
            kept = os.path.join(a.work, "%s-%d" % (kind, number))
            shutil.rmtree(kept, ignore_errors=True)
            shutil.copytree(run_dir, kept)
            with open(os.path.join(kept, "cmd.txt"), "w") as o:
                o.write("seed mesh: %s\ndamage: %s\n%s\n" % (name, "; ".join(steps), " ".join(args)))
            with open(os.path.join(kept, "stderr.txt"), "w") as o:
                o.write(err)
            print("%s %d: %s (%s; %s) %s" % (kind.upper(), number, what, os.path.basename(name), "; ".join(steps),
                                             " ".join(x for x in args if x != a.meshcvt)), flush=True)

        if a.slow > 0 and took > a.slow:
            slow += 1
            keep("slow", slow, "%.1f s" % took)
        key = "error" if "meshcvt: error" in err else "ok"
        if key == "error" and any(r in err for r in FAULT_RESULTS.values()):
            key = "gpu fault"
        outcomes[key] = outcomes.get(key, 0) + 1
        if problem:
            failures += 1
            keep("fail", failures, problem)
    print("%d runs, %d failures; %s" % (runs, failures, ", ".join("%s %d" % kv for kv in sorted(outcomes.items()))))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""CPU/GPU consistency on damaged meshes: `meshcvt cluster --device cpu` against `--device gpu`.

The doctests and tests/cli/gpu.sh compare the two engines on a fixed set of meshes and options
(issue 4's table), on lavapipe in CI. This sweep widens that on whatever device `--device gpu`
picks (an NVIDIA card where the device tool lends one): it damages real meshes the way
bench/pipeline_stress.py does (holes, fins, welded or collapsed faces, stray parts, far offsets,
...), picks a random metric, topology mode, count, initialization, gradation, Lloyd steps and
accelerator setting, and runs both engines with the same options.

A run passes when both engines
  * succeed with the same labels (face for face), the same iteration count, the same history of
    energies, moves and rounds, and the same repair counts, or
  * both fail with the same error line (a damaged mesh the clustering refuses);
and fails on anything else. Failing cases are kept in WORK/fail-N/ with the damaged mesh, the
command line and both engines' stderr, so that they can be rerun.

usage: bench/gpu_consistency_sweep.py MESHCVT SECONDS MESH.off... [--runs N] [--seed S] [--jobs J]
                                      [--work DIR] [--timeout T] [--device gpu|gpu:N]
Prints one line per failure and a summary; exit status 1 when anything failed. With a fixed seed
the runs are the same every time (with J jobs, in another order); --runs N makes exactly N runs
(SECONDS is then ignored), as tests/cli/gpu_damaged.sh does.
"""
import argparse
import concurrent.futures
import json
import os
import random
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pipeline_stress  # noqa: E402  (the damage and the writers)


def choose(rng, seed_mesh):
    """The damaged mesh and the options of one run."""
    verts, faces = seed_mesh
    steps = []
    for _ in range(rng.choice([0, 1, 1, 2])):
        if not faces or not verts:
            break
        verts, faces, what = rng.choice(pipeline_stress.DAMAGE)(rng, verts, faces)
        steps.append(what)
    if not faces:
        faces = [[0, 0, 0]] if verts else []
    nfaces = max(1, len(faces))
    n = rng.choice([1, 2, 3, 17, 200, max(4, nfaces // 40), max(4, nfaces // 10), max(4, nfaces // 4)])
    options = ["-n", str(n), "--metric", rng.choice(["cvt", "ccvt", "l21"]),
               "--topology", rng.choice(["preserving", "paper"])]
    if rng.random() < 0.2:
        options += ["--init", "random", "--seed", str(rng.randrange(1000))]
    if rng.random() < 0.2 and "l21" not in options:
        options += ["--gradation", rng.choice(["0.5", "1", "2"])]
    if rng.random() < 0.2:
        options += ["--lloyd-steps", rng.choice(["0", "3"])]
    if rng.random() < 0.2:
        options += ["--no-accelerate"]
    if rng.random() < 0.2:
        options += ["--max-iter", rng.choice(["1", "5"])]
    return verts, faces, steps, rng.choice([".off", ".obj", ".ply", ".stl"]), options


def run_engine(meshcvt, mesh_path, options, device, run_dir, timeout):
    labels = os.path.join(run_dir, "labels-%s.txt" % device.split(":")[0])
    report = os.path.join(run_dir, "report-%s.json" % device.split(":")[0])
    args = [meshcvt, "cluster", mesh_path, "-o", os.path.join(run_dir, "out-%s.ply" % device.split(":")[0]),
            "--labels", labels, "--report", report, "--device", device, "-q"] + options
    try:
        p = subprocess.run(args, capture_output=True, text=True, timeout=timeout)
        rc, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired:
        rc, err = "timeout", ""
    result = {"rc": rc, "err": err, "args": args}
    if rc == 0:
        with open(labels) as f:
            result["labels"] = f.read()
        with open(report) as f:
            r = json.load(f)
        result["trace"] = (r["iterations"], r["converged"], r["repair"],
                           [(h["energy"], h["moves"], h["round"]) for h in r["history"]])
    return result


def error_line(err):
    lines = [l for l in err.splitlines() if l.startswith("meshcvt: error")]
    return lines[0] if lines else None


SEEDS = []  # (name, (vertices, faces)) per seed mesh, read once in each worker


def load_seeds(paths):
    SEEDS[:] = [(os.path.basename(m), pipeline_stress.read_off(m)) for m in paths]


def one_run(meshcvt, device, seed_index, run_seed, work, timeout):
    seed_name, seed_mesh = SEEDS[seed_index]
    rng = random.Random(run_seed)
    verts, faces, steps, ext, options = choose(rng, seed_mesh)
    run_dir = os.path.join(work, "run-%d" % run_seed)
    shutil.rmtree(run_dir, ignore_errors=True)
    os.makedirs(run_dir)
    mesh_path = os.path.join(run_dir, "in" + ext)
    pipeline_stress.write(mesh_path, verts, faces)
    cpu = run_engine(meshcvt, mesh_path, options, "cpu", run_dir, timeout)
    gpu = run_engine(meshcvt, mesh_path, options, device, run_dir, timeout)
    problem = None
    if cpu["rc"] == "timeout" or gpu["rc"] == "timeout":
        problem = "timeout after %g s (cpu %s, gpu %s)" % (timeout, cpu["rc"], gpu["rc"])
    elif cpu["rc"] != gpu["rc"]:
        problem = "exit status cpu %s, gpu %s: %s" % (cpu["rc"], gpu["rc"], error_line(cpu["err"] + gpu["err"]))
    elif cpu["rc"] != 0:
        if error_line(cpu["err"]) != error_line(gpu["err"]) or error_line(cpu["err"]) is None:
            problem = "different errors: %s | %s" % (error_line(cpu["err"]), error_line(gpu["err"]))
    elif cpu["labels"] != gpu["labels"]:
        a, b = cpu["labels"].split(), gpu["labels"].split()
        problem = "labels differ at %d of %d faces" % (sum(x != y for x, y in zip(a, b)) + abs(len(a) - len(b)), len(a))
    elif cpu["trace"] != gpu["trace"]:
        problem = "same labels, different iterations, history or repair"
    if problem:
        with open(os.path.join(run_dir, "cmd.txt"), "w") as o:
            o.write("seed mesh: %s\ndamage: %s\n%s\n%s\n" % (seed_name, "; ".join(steps), " ".join(cpu["args"]),
                                                         " ".join(gpu["args"])))
        for name, r in (("cpu", cpu), ("gpu", gpu)):
            with open(os.path.join(run_dir, "stderr-%s.txt" % name), "w") as o:
                o.write(r["err"])
    else:
        shutil.rmtree(run_dir, ignore_errors=True)
    outcome = "error" if cpu["rc"] not in (0, "timeout") else "ok"
    return run_seed, seed_name, steps, options, problem, outcome


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshcvt")
    ap.add_argument("seconds", type=float)
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--work", default="bench/work/gpu-sweep")
    ap.add_argument("--timeout", type=float, default=120)
    ap.add_argument("--device", default="gpu")
    ap.add_argument("--runs", type=int, default=0, help="exactly this many runs (0: until SECONDS are up)")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    end = time.time() + a.seconds
    submitted = 0

    def more():
        return submitted < a.runs if a.runs > 0 else time.time() < end
    rng = random.Random(a.seed)
    runs = failures = 0
    outcomes = {}
    with concurrent.futures.ProcessPoolExecutor(max_workers=a.jobs, initializer=load_seeds,
                                                initargs=(a.meshes,)) as pool:
        pending = set()
        while pending or more():
            while more() and len(pending) < 2 * a.jobs:
                submitted += 1
                pending.add(pool.submit(one_run, a.meshcvt, a.device, rng.randrange(len(a.meshes)),
                                        rng.randrange(1 << 30), a.work, a.timeout))
            done, pending = concurrent.futures.wait(pending, return_when=concurrent.futures.FIRST_COMPLETED)
            for future in done:
                run_seed, name, steps, options, problem, outcome = future.result()
                runs += 1
                outcomes[outcome] = outcomes.get(outcome, 0) + 1
                if problem:
                    failures += 1
                    print("FAIL (run-%d): %s (%s; %s) %s" % (run_seed, problem, name, "; ".join(steps),
                                                            " ".join(options)), flush=True)
    print("%d runs (%s), %d failed" % (runs, ", ".join("%s %d" % kv for kv in sorted(outcomes.items())), failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

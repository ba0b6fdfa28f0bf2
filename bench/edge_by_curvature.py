#!/usr/bin/python3
"""Average edge length of coarse meshes in the high- and low-curvature parts of their input,
measured independently of meshcvt (numpy + scipy), for bench/gradation_bench.sh.

usage: edge_by_curvature.py INPUT.off COARSE.off [COARSE.off ...]

Input curvature per face: the mean over its edge neighbours of (angle between the two normals) /
(distance between the centroids), averaged over the 24 nearest face centroids, times the bounding
box diagonal. 'high' = the input faces in the top 20% of that value, 'low' = the bottom 50%. Each
coarse edge is classed by the input face whose centroid is nearest the edge's midpoint."""
import sys, numpy as np
from scipy.spatial import cKDTree

def read_off(p):
    tok = []
    for line in open(p):
        tok += line.split('#')[0].split()
    assert tok[0] == 'OFF'
    nv, nf = int(tok[1]), int(tok[2]); k = 4
    V = np.array(tok[k:k + 3 * nv], float).reshape(nv, 3); k += 3 * nv
    F = []
    for _ in range(nf):
        n = int(tok[k]); idx = [int(x) for x in tok[k + 1:k + 1 + n]]; k += n + 1
        for i in range(1, n - 1): F.append((idx[0], idx[i], idx[i + 1]))
    return V, np.array(F)

def face_curvature(V, F):
    diag = np.linalg.norm(V[np.unique(F)].max(0) - V[np.unique(F)].min(0))
    c = V[F].mean(1)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    edges = {}
    for f, t in enumerate(F):
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            edges.setdefault((min(a, b), max(a, b)), []).append(f)
    s = np.zeros(len(F)); cnt = np.zeros(len(F))
    for fs in edges.values():
        if len(fs) == 2:
            f, g = fs
            ang = np.arctan2(np.linalg.norm(np.cross(n[f], n[g])), n[f] @ n[g])
            k = ang / max(np.linalg.norm(c[f] - c[g]), 1e-300)
            s[f] += k; s[g] += k; cnt[f] += 1; cnt[g] += 1
    k = np.where(cnt > 0, s / np.maximum(cnt, 1), 0) * diag
    tree = cKDTree(c)
    _, nb = tree.query(c, 24)
    return k[nb].mean(1), tree

V, F = read_off(sys.argv[1])
kf, tree = face_curvature(V, F)
hi_t, lo_t = np.quantile(kf, 0.8), np.quantile(kf, 0.5)
print(f"input {sys.argv[1]}: {len(F)} faces, curvature*diag quantiles 50% {lo_t:.3g}, 80% {hi_t:.3g}")
for out in sys.argv[2:]:
    W, G = read_off(out)
    E = set()
    for t in G:
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])): E.add((min(a, b), max(a, b)))
    E = np.array(sorted(E))
    L = np.linalg.norm(W[E[:, 0]] - W[E[:, 1]], axis=1)
    _, f = tree.query((W[E[:, 0]] + W[E[:, 1]]) / 2)
    hi, lo = L[kf[f] >= hi_t], L[kf[f] <= lo_t]
    print(f"  {out}: {len(E)} edges; mean edge length high-curvature {hi.mean():.4g} ({len(hi)} edges), "
          f"low-curvature {lo.mean():.4g} ({len(lo)} edges), ratio low/high {lo.mean() / hi.mean():.2f}")

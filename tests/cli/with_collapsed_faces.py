#!/usr/bin/env python3
"""Writes an OFF mesh with collapsed faces appended, as welding slivers leaves them: for COUNT faces
spread evenly over the input (every (faces // COUNT)-th), a face (b, b, c) from its corners (a, b, c).
usage: with_collapsed_faces.py IN.off OUT.off COUNT   (IN: triangles only, no comments)"""
import sys

tok = open(sys.argv[1]).read().split()
count = int(sys.argv[3])
nv, nf = int(tok[1]), int(tok[2])
body = tok[4:]
faces = [body[3 * nv + 4 * k: 3 * nv + 4 * k + 4] for k in range(nf)]
extra = [['3', f[2], f[2], f[3]] for f in faces[:: nf // count][:count]]
with open(sys.argv[2], 'w') as out:
    out.write(f"OFF\n{nv} {nf + len(extra)} 0\n")
    for i in range(nv):
        out.write(' '.join(body[3 * i:3 * i + 3]) + '\n')
    for f in faces + extra:
        out.write(' '.join(f) + '\n')

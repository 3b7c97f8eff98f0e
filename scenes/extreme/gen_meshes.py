#!/usr/bin/env python3
"""Writes the OBJ meshes of scenes/extreme/ (run from that folder; the files
are committed, this documents how they were made).

  icosphere.obj  unit icosphere, icosahedron subdivided 3 times: 642 shared
                 vertices, 1280 triangles, every edge shared by exactly two
                 faces (a closed 2-manifold), outward winding.
  ico0.obj       the bare icosahedron: 12 vertices where 5 faces meet.
  grid.obj       an 8x8 grid of unit quads in the plane y = 0 (x, z in
                 [-4, 4]), split along alternating diagonals: 128
                 axis-aligned flat triangles, grid lines through x = 0, z = 0.
  cancel.obj     two triangles whose vertex normals cancel (vn 1 0 0 and
                 vn -1 0 0 and a zero vn), and one whose normals are all zero.
"""
import math


def icosphere(levels):
    t = (1 + math.sqrt(5)) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0),
             (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
             (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
             (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
             (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
             (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]

    def unit(v):
        n = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
        return (v[0] / n, v[1] / n, v[2] / n)

    verts = [unit(v) for v in verts]
    for _ in range(levels):
        cache = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                va, vb = verts[a], verts[b]
                verts.append(unit(((va[0] + vb[0]) / 2, (va[1] + vb[1]) / 2, (va[2] + vb[2]) / 2)))
                cache[key] = len(verts) - 1
            return cache[key]

        nf = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = nf
    return verts, faces


def write(path, header, verts, faces, normals=None, face_normals=None):
    with open(path, "w") as f:
        f.write(header)
        for v in verts:
            f.write("v %.17g %.17g %.17g\n" % v)
        for n in normals or []:
            f.write("vn %.17g %.17g %.17g\n" % n)
        for i, (a, b, c) in enumerate(faces):
            if face_normals:
                na, nb, nc = face_normals[i]
                f.write("f %d//%d %d//%d %d//%d\n" % (a + 1, na + 1, b + 1, nb + 1, c + 1, nc + 1))
            else:
                f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))


v, f = icosphere(3)
write("icosphere.obj", "# Unit icosphere (icosahedron subdivided 3 times), closed, written by gen_meshes.py.\n", v, f)
v, f = icosphere(0)
write("ico0.obj", "# Unit icosahedron, closed, written by gen_meshes.py.\n", v, f)

verts, faces = [], []
for j in range(9):
    for i in range(9):
        verts.append((float(i - 4), 0.0, float(j - 4)))
for j in range(8):
    for i in range(8):
        a, b, c, d = j * 9 + i, j * 9 + i + 1, (j + 1) * 9 + i + 1, (j + 1) * 9 + i
        if (i + j) % 2 == 0:
            faces += [(a, d, c), (a, c, b)]
        else:
            faces += [(a, d, b), (b, d, c)]
write("grid.obj", "# 8x8 unit quads in y = 0, alternating diagonals: 128 flat axis-aligned triangles (gen_meshes.py).\n",
      verts, faces)

verts = [(-2.0, -1.5, 0.0), (2.0, -1.5, 0.0), (0.0, 1.5, 0.0), (2.0, 1.5, 0.0), (4.0, -1.5, 0.0), (6.0, 1.5, 0.0)]
normals = [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 0.0)]
faces = [(0, 1, 2), (1, 3, 2), (1, 4, 3)]
fn = [(0, 1, 2), (0, 1, 1), (2, 2, 2)]
write("cancel.obj", "# Vertex normals that cancel (1 0 0 against -1 0 0, and zero normals) (gen_meshes.py).\n",
      verts, faces, normals, fn)

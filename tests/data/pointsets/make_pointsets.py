#!/usr/bin/python3
"""Rebuild the point sets in this folder from CGAL's data files.

Input: the `data/` folder of Debian's libcgal-demo 5.5.1-2, got once with
    apt-get download libcgal-demo && dpkg -x libcgal-demo_5.5.1-2_all.deb pkg
    mkdir cgal && tar xzf pkg/usr/share/doc/libcgal-dev/data.tar.gz -C cgal
    /usr/bin/python3 make_pointsets.py cgal/data .
Needs only numpy (made with Debian's python3-numpy 1.24.2). Coordinates and
normals that come from a point file are copied as the original text tokens,
so those files are lossless; see PROVENANCE.md for what each file is.
"""
import sys, os
import numpy as np

SRC = "CGAL 5.5.1 data, Debian libcgal-demo 5.5.1-2"
LIC = "CC0-1.0 (CGAL LICENSE: files without an explicit copyright notice)"


def write_ply(path, rows, comments, normals=True):
    """rows: list of lists of text tokens (x y z [nx ny nz])."""
    props = ["x", "y", "z"] + (["nx", "ny", "nz"] if normals else [])
    with open(path, "w", newline="\n") as f:
        f.write("ply\nformat ascii 1.0\n")
        for c in comments:
            f.write("comment %s\n" % c)
        f.write("element vertex %d\n" % len(rows))
        for p in props:
            f.write("property float %s\n" % p)
        f.write("end_header\n")
        for r in rows:
            assert len(r) == len(props)
            f.write(" ".join(r) + "\n")


def read_tokens(path, ncols):
    rows = []
    with open(path) as f:
        for line in f:
            t = line.split()
            if t:
                rows.append(t[:ncols])
    return rows


def read_off(path):
    toks = []
    with open(path) as f:
        for line in f:
            toks += line.split("#")[0].split()
    assert toks[0] == "OFF"
    nv, nf = int(toks[1]), int(toks[2])
    i = 4
    vtok = [toks[i + 3 * k:i + 3 * k + 3] for k in range(nv)]
    i += 3 * nv
    faces = []
    for _ in range(nf):
        k = int(toks[i])
        faces.append([int(x) for x in toks[i + 1:i + 1 + k]])
        i += 1 + k
    return vtok, np.array(vtok, float), np.array(faces, int)


def main(data, out):
    # (a) cube.pwn: 50000 points with unit normals, copied as is.
    rows = read_tokens(os.path.join(data, "points_3/cube.pwn"), 6)
    write_ply(os.path.join(out, "cgal_cube.ply"), rows,
              [SRC + ", points_3/cube.pwn, all points, tokens copied", LIC,
               "normals are unoriented (sign arbitrary)"])

    # (b, d) kitten.xyz: 5210 points with outward unit normals, copied as is.
    rows = read_tokens(os.path.join(data, "points_3/kitten.xyz"), 6)
    write_ply(os.path.join(out, "cgal_kitten.ply"), rows,
              [SRC + ", points_3/kitten.xyz, all points, tokens copied", LIC])

    # (b) knot1.off: 20000 points sampled on the faces (area-weighted,
    # numpy default_rng(1)), normal = outward unit face normal.
    _, V, F = read_off(os.path.join(data, "meshes/knot1.off"))
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    cr = np.cross(b - a, c - a)
    area = np.linalg.norm(cr, axis=1)
    fn = cr / area[:, None]
    rng = np.random.default_rng(1)
    n = 20000
    fi = rng.choice(len(F), size=n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    P = (1 - s)[:, None] * a[fi] + (s * (1 - r2))[:, None] * b[fi] + (s * r2)[:, None] * c[fi]
    N = fn[fi]
    rows = [["%.9g" % x for x in p] + ["%.6f" % x for x in q] for p, q in zip(P, N)]
    write_ply(os.path.join(out, "cgal_knot1_sampled.ply"), rows,
              [SRC + ", meshes/knot1.off, 20000 area-weighted samples, numpy default_rng(1)",
               LIC, "normals = outward face normals"])

    # (d) bear.off: the mesh's 13826 vertices (tokens copied), faces dropped;
    # normal = normalised sum of the adjacent faces' area-weighted normals.
    vtok, V, F = read_off(os.path.join(data, "meshes/bear.off"))
    cr = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    VN = np.zeros_like(V)
    for k in range(3):
        np.add.at(VN, F[:, k], cr)
    VN /= np.linalg.norm(VN, axis=1)[:, None]
    rows = [t + ["%.6f" % x for x in q] for t, q in zip(vtok, VN)]
    write_ply(os.path.join(out, "cgal_bear_vertices.ply"), rows,
              [SRC + ", meshes/bear.off, vertices only, faces dropped", LIC,
               "normals = area-weighted vertex normals of the mesh, outward"])

    # (c) building.ply: real-world point cloud, every second point (0, 2, 4, ...),
    # x y z nx ny nz tokens copied, segment_index dropped.
    with open(os.path.join(data, "points_3/building.ply")) as f:
        lines = f.read().split("end_header\n", 1)[1].split("\n")
    rows = [l.split()[:6] for l in lines if l.strip()]
    assert len(rows) == 100000
    write_ply(os.path.join(out, "cgal_building_half.ply"), rows[::2],
              [SRC + ", points_3/building.ply, every 2nd point, segment_index dropped",
               LIC, "normals as given (not checked for orientation)"])


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])

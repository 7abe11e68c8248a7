"""Side-by-side figures for the scan front end (issue 16) in docs/PERFORMANCE.md, one run, one machine.

Runs cmmd's scan_bench (Google Benchmark) and, on exactly the clouds it writes (--dump):
  (a) thinning: our k-d tree + quadric fits (k 25) + bin size + uniform voxel thinning against Open3D's
      estimate_normals(KDTreeSearchParamKNN(25)) on the full cloud + voxel_down_sample(B), at ~300k
      and ~1M points;
  (b) triangulation of the same thinned cloud (our fitted normals, oriented by the scanner's): ours
      against Open3D's ball pivoting and PCL's greedy projection (pcl_gp3_surface): time, peak
      memory, boundary loops that are not real openings, non-manifold edges, distance to the true
      surface.
Prints Markdown tables. Needs Debian's Open3D and pcl-tools (apt-get install python3-open3d
pcl-tools); run with Debian's interpreter:
    /usr/bin/python3 bench/compare_scan.py build/bench/bench/scan_bench [--repetitions 3] [--dir DIR]
"""
import argparse
import json
import os
import platform
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import open3d as o3d

SIZES = [int(x) for x in os.environ.get("CMMD_SCAN_SIZES", "300000,1000000").split(",")]  # scan_bench's Args
KNN = 25
BPA_RADII = [1, 1.5, 2, 3]      # × B
GP3_RADIUS, GP3_MU = 3, 2.5     # × B; pcl_gp3_surface keeps GP3's default of 100 nearest neighbours
SAMPLES = 400_000               # points sampled on each mesh for its distance to the true surface


# --- memory: VmHWM of this process, reset before the measured step (Linux ≥ 4.0) ---------------

def status_kb(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field):
                return int(line.split()[1])
    return -1


def reset_peak():
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


# --- the Open3D steps, shared by the timing loops and the --child processes ----------------------

def o3d_thin(points, bin_mm):
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    start = time.perf_counter()
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(KNN))
    down = pcd.voxel_down_sample(bin_mm)
    return time.perf_counter() - start, down


def o3d_bpa(pcd, bin_mm):
    radii = o3d.utility.DoubleVector([r * bin_mm for r in BPA_RADII])
    start = time.perf_counter()
    mesh = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(pcd, radii)
    return time.perf_counter() - start, mesh


def cpu_seconds():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def child(args):
    """One step in its own process (wall and CPU time, peak memory): prints a JSON line."""
    kind, path, bin_mm = args[0], args[1], float(args[2])
    if kind == "thin":
        points = np.asarray(o3d.io.read_point_cloud(path).points).copy()  # points only: normals are estimated
        before = status_kb("VmRSS:")
        reset = reset_peak()
        cpu = cpu_seconds()
        seconds, down = o3d_thin(points, bin_mm)
        result = len(down.points)
    else:
        pcd = o3d.io.read_point_cloud(path)
        before = status_kb("VmRSS:")
        reset = reset_peak()
        cpu = cpu_seconds()
        seconds, mesh = o3d_bpa(pcd, bin_mm)
        result = len(mesh.triangles)
    cpu = cpu_seconds() - cpu
    peak = status_kb("VmHWM:")
    if kind == "bpa" and len(args) > 3:
        o3d.io.write_triangle_mesh(args[3], mesh)
    print(json.dumps({"stage": kind, "seconds": seconds, "cpu_seconds": cpu, "result": result,
                      "rss_before_kb": before, "peak_kb": peak, "peak_reset": reset}))


# --- running things -------------------------------------------------------------------------------

def timed_process(command):
    """Runs command under /usr/bin/time -v: (stdout, stderr without time's report, max RSS kB, wall s)."""
    start = time.perf_counter()
    done = subprocess.run(["/usr/bin/time", "-v"] + command, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr[-3000:]}")
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr).group(1))
    cpu = sum(float(re.search(rf"{k} time \(seconds\): ([0-9.]+)", done.stderr).group(1)) for k in ("User", "System"))
    return done.stdout, done.stderr, rss, wall, cpu


def json_line(text):
    return json.loads([l for l in text.splitlines() if l.startswith("{")][-1])


def run_ours(binary, repetitions, saved, reuse):
    if reuse and os.path.exists(saved):
        out = open(saved).read()
    else:
        out = subprocess.run(
            [binary, "--benchmark_format=json", f"--benchmark_repetitions={repetitions}",
             "--benchmark_report_aggregates_only=true"],
            check=True, capture_output=True, text=True).stdout
        open(saved, "w").write(out)
    medians = {}
    for b in json.loads(out)["benchmarks"]:
        # with one repetition Google Benchmark reports the run itself, no aggregates
        if b.get("aggregate_name") != "median" and not (repetitions == 1 and b.get("run_type") == "iteration"):
            continue
        name, size = b["run_name"].split("/")[:2]
        medians[(name, int(size))] = b
    return medians


def run_gp3(pcd_path, vtk_path, bin_mm):
    out, err, rss, wall, cpu = timed_process(["pcl_gp3_surface", pcd_path, vtk_path, "-radius", f"{GP3_RADIUS * bin_mm}",
                                         "-mu", f"{GP3_MU}"])
    # "Computing" goes to stderr and its "[done, … ms : N polygons]" to stdout: the first polygons
    # line is the triangulation, the second the saving.
    text = re.sub(r"\x1b\[[0-9;]*m", "", out)  # PCL colours its console output
    load = float(re.search(r"\[done, ([0-9.e+]+) ms : \d+ points\]", text).group(1))
    compute, save = (float(x) for x in re.findall(r"\[done, ([0-9.e+]+) ms : \d+ polygons\]", text)[:2])
    return {"seconds": compute / 1e3, "load_ms": load, "save_ms": save, "wall_s": wall, "rss_kb": rss, "cpu_seconds": cpu}


def read_vtk(path):
    """PCL's legacy ASCII VTK polydata: (vertices, triangles). The vertices are written with 5 digits;
    GP3 keeps the input's points in order, so the caller takes them from the input instead."""
    tokens = open(path).read().split()
    i = tokens.index("POINTS")
    n = int(tokens[i + 1])
    vertices = np.array(tokens[i + 3:i + 3 + 3 * n], dtype=float).reshape(n, 3)
    i = tokens.index("POLYGONS")
    m = int(tokens[i + 1])
    data = np.array(tokens[i + 3:i + 3 + 4 * m], dtype=np.int64).reshape(m, 4)
    assert (data[:, 0] == 3).all(), "non-triangle polygon"
    return vertices, data[:, 1:]


# --- mesh quality ----------------------------------------------------------------------------------

def edge_counts(triangles):
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return unique, counts


def boundary_components(vertices, boundary_edges):
    """Connected components of the boundary edges: [(centroid, length, edge count)]."""
    parent = {}

    def find(a):
        while parent.setdefault(a, a) != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for a, b in boundary_edges:
        ra, rb = find(int(a)), find(int(b))
        if ra != rb:
            parent[ra] = rb
    groups = {}
    for a, b in boundary_edges:
        groups.setdefault(find(int(a)), []).append((int(a), int(b)))
    out = []
    for edges in groups.values():
        ids = np.unique(np.array(edges).ravel())
        length = sum(np.linalg.norm(vertices[a] - vertices[b]) for a, b in edges)
        out.append((vertices[ids].mean(axis=0), length, len(edges)))
    return out


def match_openings(components, borders):
    """Each true border takes the unmatched loop of similar length nearest its centre."""
    free = list(range(len(components)))
    matched = []
    for border in sorted(borders, key=lambda b: -b["perimeter_mm"]):
        centre, perimeter = np.array(border["centre"]), border["perimeter_mm"]
        best = None
        for i in free:
            c, length, _ = components[i]
            d = np.linalg.norm(c - centre)
            if 0.6 * perimeter <= length <= 1.8 * perimeter and d <= max(2.0, 0.1 * perimeter):
                if best is None or d < best[0]:
                    best = (d, i)
        if best is not None:
            free.remove(best[1])
            matched.append(best[1])
    return matched, free


def quality(vertices, triangles, borders, truth_scene):
    unique, counts = edge_counts(triangles)
    boundary = unique[counts == 1]
    components = boundary_components(vertices, boundary)
    matched, false = match_openings(components, borders)
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vertices), o3d.utility.Vector3iVector(triangles))
    samples = np.asarray(mesh.sample_points_uniformly(number_of_points=SAMPLES).points)
    used = vertices[np.unique(triangles)]
    query = o3d.core.Tensor(np.concatenate([samples, used]).astype(np.float32))
    distance = truth_scene.compute_distance(query).numpy()
    return {
        "vertices": len(np.unique(triangles)), "triangles": len(triangles),
        "boundary_edges": int((counts == 1).sum()), "loops": len(components),
        "openings_matched": len(matched), "false_loops": len(false),
        "false_loop_edges": int(sum(components[i][2] for i in false)),
        "non_manifold_edges": int((counts > 2).sum()),
        "mean": float(distance.mean()), "p997": float(np.percentile(distance, 99.7)), "max": float(distance.max()),
    }


def mb(kb):
    return f"{kb / 1024:.0f}"


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        return child(sys.argv[2:])
    parser = argparse.ArgumentParser()
    parser.add_argument("binary")
    parser.add_argument("--repetitions", type=int, default=3)
    parser.add_argument("--dir", default=os.path.join(tempfile.gettempdir(), "cmmd_scan_bench"))
    parser.add_argument("--reuse", action="store_true", help="reuse the clouds and our benchmark figures in DIR (debugging)")
    args = parser.parse_args()
    binary, reps, d = os.path.abspath(args.binary), args.repetitions, args.dir
    me = os.path.abspath(__file__)

    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    pcl = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "pcl-tools"], capture_output=True, text=True).stdout
    load_start = os.getloadavg()
    started = time.strftime("%Y-%m-%d %H:%M")

    if not (args.reuse and os.path.exists(os.path.join(d, f"info_{SIZES[-1]}.json"))):
        subprocess.run([binary, f"--dump={d}"], check=True)
    info = {s: json.load(open(os.path.join(d, f"info_{s}.json"))) for s in SIZES}
    ours = run_ours(binary, reps, os.path.join(d, "scan_bench.json"), args.reuse)

    truth = o3d.io.read_triangle_mesh(os.path.join(d, "truth.ply"))
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(truth))

    def ours_stage(stage, cloud):
        out, _, rss, _, _ = timed_process([binary, f"--stage={stage}", f"--cloud={cloud}"])
        return dict(json_line(out), rss_kb=rss)

    def o3d_child(kind, path, bin_mm, *extra):
        out, _, rss, _, _ = timed_process([sys.executable, me, "--child", kind, path, f"{bin_mm!r}", *extra])
        return dict(json_line(out), rss_kb=rss)

    results, quality_rows = {}, []
    for s in SIZES:
        i = info[s]
        B = i["bin_mm"]
        raw_path, thin_ply, thin_pcd = (os.path.join(d, f) for f in (f"raw_{s}.ply", f"thinned_{s}.ply", f"thinned_{s}.pcd"))
        bpa_path, gp3_path = os.path.join(d, f"bpa_{s}.ply"), os.path.join(d, f"gp3_{s}.vtk")
        # Each step in its own process (its peak memory alone), the tools interleaved round by round so
        # that they share whatever load the machine has. Open3D thins at the B our thinning found on the
        # full cloud (strays and all, so it can differ from the outlier-free pipeline's B).
        thin_bin = ours[("bm_thin", s)]["bin_mm"]
        runs = {k: [] for k in ("ours_thin", "o3d_thin", "ours_triangulate", "o3d_bpa", "gp3")}
        for _ in range(reps):
            runs["ours_thin"].append(ours_stage("thin", raw_path))
            runs["o3d_thin"].append(o3d_child("thin", raw_path, thin_bin))
            runs["ours_triangulate"].append(ours_stage("triangulate", raw_path))
            runs["o3d_bpa"].append(o3d_child("bpa", thin_ply, B, bpa_path))
            runs["gp3"].append(run_gp3(thin_pcd, gp3_path, B))
        runs["ours_mesh_scan"] = [ours_stage("mesh_scan", raw_path)]
        results[s] = runs

        m = o3d.io.read_triangle_mesh(os.path.join(d, f"ours_{s}.ply"))
        q_ours = quality(np.asarray(m.vertices), np.asarray(m.triangles), i["borders"], scene)
        bpa = o3d.io.read_triangle_mesh(bpa_path)
        q_bpa = quality(np.asarray(bpa.vertices), np.asarray(bpa.triangles), i["borders"], scene)
        gv, gt = read_vtk(gp3_path)
        exact = np.asarray(o3d.io.read_point_cloud(thin_ply).points)
        assert len(gv) == len(exact) and np.abs(gv - exact).max() < 1e-2, "GP3 reordered the points"
        q_gp3 = quality(exact, gt, i["borders"], scene)
        quality_rows.append((s, i, {"cmmd region growing": q_ours, "Open3D ball pivoting": q_bpa,
                                    "PCL greedy projection": q_gp3}))

    load_end = os.getloadavg()
    print(f"Run {started}. Machine: {cpu}, {os.cpu_count()} cores, {platform.platform()}; Open3D {o3d.__version__}, "
          f"PCL {pcl} (pcl-tools); Python {platform.python_version()}. Medians of {reps} runs. "
          f"Load average (1/5/15 min) {load_start[0]:.1f}/{load_start[1]:.1f}/{load_start[2]:.1f} at the start, "
          f"{load_end[0]:.1f}/{load_end[1]:.1f}/{load_end[2]:.1f} at the end.\n")
    print("Inputs: raw scans of the case-3 block (sim::synthesize_raw_scan, 7 views, σ 0.05 mm, 0.2 % strays), "
          f"ε = 0.05 mm; BPA radii {BPA_RADII} × B; pcl_gp3_surface -radius {GP3_RADIUS}·B -mu {GP3_MU} "
          "(GP3's defaults otherwise: 100 nearest neighbours, angles 10°–120°, surface angle 45°).\n")

    med = lambda runs, key: statistics.median(r[key] for r in runs)

    print("### Thinning the full cloud (normals / fits on the full cloud)\n")
    print("Wall and CPU (user + system, both cores) times: medians of the interleaved runs, each in its own process; "
          "`bm_thin`: Google Benchmark's median, run before them.\n")
    print("| raw points | spacing (mm) | B (mm) | cmmd `bm_thin` (ms) | cmmd wall (ms) | cmmd CPU (s) | kept | "
          "Open3D wall (ms) | Open3D CPU (s) | kept | cmmd / Open3D, wall | cmmd / Open3D, CPU |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for s in SIZES:
        i, thin, r = info[s], ours[("bm_thin", s)], results[s]
        ow, oc = med(r["ours_thin"], "seconds") * 1e3, med(r["ours_thin"], "cpu_seconds")
        tw, tc = med(r["o3d_thin"], "seconds") * 1e3, med(r["o3d_thin"], "cpu_seconds")
        print(f"| {i['points']:,} | {i['spacing_mm']:.3f} | {thin['bin_mm']:.4f} | {thin['real_time']:.0f} | {ow:.0f} | {oc:.2f} | "
              f"{int(thin['kept']):,} | {tw:.0f} | {tc:.2f} | {r['o3d_thin'][0]['result']:,} | {ow / tw:.2f} | {oc / tc:.2f} |")

    print("\n### Triangulating the same thinned cloud\n")
    print("PCL: the triangulation's own time as pcl_gp3_surface prints it (its loading and saving left out); its "
          "CPU time is the whole process's. cmmd `bm_triangulate`: Google Benchmark's median.\n")
    print("| raw points | thinned points (B mm) | cmmd `bm_triangulate` (ms) | cmmd wall (ms) | cmmd CPU (s) | "
          "Open3D BPA wall (ms) | BPA CPU (s) | PCL GP3 wall (ms) | GP3 CPU (s) | cmmd / fastest other, wall |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for s in SIZES:
        i, tri, r = info[s], ours[("bm_triangulate", s)], results[s]
        ow, oc = med(r["ours_triangulate"], "seconds") * 1e3, med(r["ours_triangulate"], "cpu_seconds")
        bw, bc = med(r["o3d_bpa"], "seconds") * 1e3, med(r["o3d_bpa"], "cpu_seconds")
        gw, gc = med(r["gp3"], "seconds") * 1e3, med(r["gp3"], "cpu_seconds")
        print(f"| {i['points']:,} | {i['thinned']:,} ({i['bin_mm']:.4f}) | {tri['real_time']:.0f} | {ow:.0f} | {oc:.2f} | "
              f"{bw:.0f} | {bc:.2f} | {gw:.0f} | {gc:.2f} | {ow / min(bw, gw):.2f} |")

    print("\n### cmmd mesh_scan, whole (Google Benchmark median) and its stages (mesh_scan's own clock, same runs; ms)\n")
    print("| raw points | mesh_scan | outliers | fit | bin size | thinning | triangulation |")
    print("|---|---|---|---|---|---|---|")
    for s in SIZES:
        b = ours[("bm_mesh_scan", s)]
        print(f"| {info[s]['points']:,} | {b['real_time']:.0f} | " +
              " | ".join(f"{b.get('s_' + k, float('nan')) * 1e3:.0f}" for k in ("outliers", "fit", "bin size", "thinning", "triangulation")) + " |")

    print("\n### Peak memory (each step in its own process; MB; the largest over the runs)\n")
    print("| raw points | step | process max RSS (`time -v`) | RSS held before the step | peak during the step |")
    print("|---|---|---|---|---|")
    names = {"ours_thin": "cmmd thinning (tree + fits + B + bins)", "o3d_thin": "Open3D normals + voxel",
             "ours_triangulate": "cmmd triangulate_scan", "o3d_bpa": "Open3D ball pivoting",
             "gp3": "PCL pcl_gp3_surface (whole process)", "ours_mesh_scan": "cmmd mesh_scan (whole)"}
    for s in SIZES:
        for key, name in names.items():
            r = results[s][key]
            rss = max(x["rss_kb"] for x in r)
            if "peak_kb" in r[0]:
                print(f"| {info[s]['points']:,} | {name} | {mb(rss)} | {mb(max(x['rss_before_kb'] for x in r))} | "
                      f"{mb(max(x['peak_kb'] for x in r))} |")
            else:
                print(f"| {info[s]['points']:,} | {name} | {mb(rss)} | — | — |")

    print("\n### Mesh quality on the same thinned cloud\n")
    print("True openings of the scan (sim::scan_borders): " +
          ", ".join(f"{b['kind']} {b['perimeter_mm']:.1f} mm" for b in info[SIZES[0]]["borders"]) + ".\n")
    print("| raw points | method | vertices used | triangles | boundary loops | true openings matched | false loops (their edges) | boundary edges | non-manifold edges | distance to true surface: mean / 99.7 % / max (mm) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for s, i, rows in quality_rows:
        n = len(i["borders"])
        for name, q in rows.items():
            print(f"| {i['points']:,} | {name} | {q['vertices']:,} | {q['triangles']:,} | {q['loops']} | {q['openings_matched']} of {n} | "
                  f"{q['false_loops']} ({q['false_loop_edges']:,}) | {q['boundary_edges']:,} | {q['non_manifold_edges']:,} | "
                  f"{q['mean']:.4f} / {q['p997']:.4f} / {q['max']:.3f} |")
    print("\nOur triangulation's own report: " + "; ".join(
        f"{info[s]['points']:,}: {info[s]['loops_outer']} outer + {info[s]['loops_hole']} hole loops, {info[s]['creases']} creases, "
        f"{info[s]['components']} components, {info[s]['pinched_vertices']} pinched vertices; B from: {info[s]['bin_source']}"
        for s in SIZES))


if __name__ == "__main__":
    main()

"""Side-by-side figures for docs/PERFORMANCE.md, from one run on one machine.

Runs cmmd's geometry_bench (Google Benchmark) and Open3D's read_triangle_mesh on the same binary
STL files, and prints a Markdown table of medians and ratios. Needs Debian's Open3D, which the
tests do not (apt-get install python3-open3d); run with Debian's interpreter:
    /usr/bin/python3 bench/compare_open3d.py build-bench/bench/geometry_bench
"""
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import open3d as o3d

SIZES = [100_000, 1_000_000, 4_000_000]
REPETITIONS = 5


def run_ours(binary):
    out = subprocess.run(
        [binary, "--benchmark_format=json", f"--benchmark_repetitions={REPETITIONS}",
         "--benchmark_report_aggregates_only=true"],
        check=True, capture_output=True, text=True).stdout
    medians = {}
    for b in json.loads(out)["benchmarks"]:
        if b.get("aggregate_name") != "median":
            continue
        name, size = b["run_name"].split("/")[:2]
        medians[(name, int(size))] = (b["real_time"], b)
    return medians


def time_open3d(path):
    times, mesh = [], None
    for _ in range(REPETITIONS):
        start = time.perf_counter()
        mesh = o3d.io.read_triangle_mesh(path)
        times.append((time.perf_counter() - start) * 1e3)
    return statistics.median(times), len(mesh.vertices), len(mesh.triangles)


def main():
    binary = sys.argv[1]
    ours = run_ours(binary)  # also writes the STL files the Open3D side reads
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    print(f"Machine: {cpu}, {os.cpu_count()} cores, {platform.platform()}; Open3D {o3d.__version__}; "
          f"medians of {REPETITIONS} runs.\n")
    print("| triangles | STL MB | cmmd read (ms) | Open3D read (ms) | Open3D / cmmd | cmmd vertices | Open3D vertices "
          "| cmmd features (ms) | features / read |")
    print("|---|---|---|---|---|---|---|---|---|")
    for size in SIZES:
        path = os.path.join(tempfile.gettempdir(), f"cmmd_bench_block_{size}.stl")
        read_ms, read = ours[("bm_read_binary_stl", size)]
        features_ms, features = ours[("bm_extract_features", size)]
        o3d_ms, o3d_vertices, o3d_triangles = time_open3d(path)
        ours_vertices = f"{int(read['vertices']):,}"
        print(f"| {int(read['triangles']):,} | {read['MB']:.0f} | {read_ms:.0f} | {o3d_ms:.0f} | "
              f"{o3d_ms / read_ms:.2f} | {ours_vertices} | {o3d_vertices:,} ({o3d_triangles:,} tri) | "
              f"{features_ms:.0f} | {features_ms / read_ms:.2f} |")


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Writes the hand-made seeds of tests/fuzz/corpus/<target>/ (files named seed-*): small meshes in
every format and encoding cut from tests/data, the broken files of tests/data/broken, the config
JSON of config/, and protocol lines and JSON-RPC requests after docs/api.md and docs/hal.md.
Inputs the fuzzer found are kept beside them under their SHA-1 names. Run from anywhere; rewrites
the seed-* files only."""
import json
import pathlib
import shutil
import struct

root = pathlib.Path(__file__).resolve().parents[2]
corpus = root / "tests/fuzz/corpus"
data = root / "tests/data"


def put(target, name, content):
    folder = corpus / target
    folder.mkdir(parents=True, exist_ok=True)
    if isinstance(content, str):
        content = content.encode()
    (folder / f"seed-{name}").write_bytes(content)


for old in corpus.glob("*/seed-*"):
    old.unlink()

# --- meshes: the first faces of fandisk.ply whose corners are among its first vertices ---------
lines = (data / "fandisk.ply").read_text().splitlines()
end = lines.index("end_header")
nv = int(next(l for l in lines if l.startswith("element vertex")).split()[2])
verts = [tuple(float(x) for x in l.split()[:3]) for l in lines[end + 1:end + 1 + nv]]
faces = []
for l in lines[end + 1 + nv:]:
    f = [int(x) for x in l.split()[1:]]
    if max(f) < 24:
        faces.append(f)
    if len(faces) == 12:
        break
used = sorted({i for f in faces for i in f})
remap = {old: new for new, old in enumerate(used)}
V = [verts[i] for i in used]
F = [[remap[i] for i in f] for f in faces]
N = [(0.0, 0.0, 1.0)] * len(V)


def ply_ascii(normals=False, with_faces=True):
    props = "property float x\nproperty float y\nproperty float z\n"
    if normals:
        props += "property float nx\nproperty float ny\nproperty float nz\n"
    head = f"ply\nformat ascii 1.0\ncomment cut from tests/data/fandisk.ply\nelement vertex {len(V)}\n{props}"
    if with_faces:
        head += f"element face {len(F)}\nproperty list uchar int vertex_indices\n"
    body = "".join(" ".join(map(str, v + (N[i] if normals else ()))) + "\n" for i, v in enumerate(V))
    if with_faces:
        body += "".join(f"3 {a} {b} {c}\n" for a, b, c in F)
    return head + "end_header\n" + body


def ply_binary(order, vtype="float", itype="int", extra=False):
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian"}[order]
    code = {"float": "f", "double": "d"}[vtype]
    icode = {"int": "i", "uint": "I", "short": "h", "uchar": "B"}[itype]
    head = f"ply\nformat {fmt} 1.0\nelement vertex {len(V)}\n"
    head += "".join(f"property {vtype} {c}\n" for c in "xyz")
    if extra:
        head += "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    head += f"element face {len(F)}\nproperty list uchar {itype} vertex_indices\n"
    if extra:
        head += "element edge 1\nproperty int vertex1\nproperty int vertex2\n"
    head += "end_header\n"
    body = b"".join(struct.pack(order + code * 3, *v) + (b"\x10\x20\x30" if extra else b"") for v in V)
    body += b"".join(struct.pack(order + "B" + icode * 3, 3, *f) for f in F)
    if extra:
        body += struct.pack(order + "ii", 0, 1)
    return head.encode() + body


put("ply", "ascii.ply", ply_ascii())
put("ply", "ascii-normals.ply", ply_ascii(normals=True))
put("ply", "ascii-cloud.ply", ply_ascii(with_faces=False))
put("ply", "binary-le.ply", ply_binary("<"))
put("ply", "binary-be-double.ply", ply_binary(">", "double", "uint"))
put("ply", "binary-le-colours-edges.ply", ply_binary("<", "float", "short", extra=True))
quad = "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\n" \
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"
put("ply", "quad.ply", quad)
# A raw scan as scanners export it: binary points with normals and no face element.
put("ply", "binary-cloud-normals.ply", (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(V)}\n"
    + "".join(f"property float {c}\n" for c in ("x", "y", "z", "nx", "ny", "nz")) + "end_header\n").encode()
    + b"".join(struct.pack("<6f", *v, *N[i]) for i, v in enumerate(V)))

solid = "solid cut\n" + "".join(
    "  facet normal 0 0 1\n    outer loop\n" + "".join(f"      vertex {x} {y} {z}\n" for x, y, z in (V[a], V[b], V[c]))
    + "    endloop\n  endfacet\n" for a, b, c in F) + "endsolid cut\n"
put("stl", "ascii.stl", solid)
binary = b"binary STL cut from tests/data/fandisk.ply".ljust(80, b" ") + struct.pack("<I", len(F))
for a, b, c in F:
    binary += struct.pack("<12fH", 0, 0, 1, *V[a], *V[b], *V[c], 0)
put("stl", "binary.stl", binary)
put("stl", "binary-starting-solid.stl", b"solid but binary".ljust(80, b" ") + binary[80:])

obj = "# cut from tests/data/fandisk.ply\no part\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in V)
put("obj", "plain.obj", obj + "".join(f"f {a+1} {b+1} {c+1}\n" for a, b, c in F))
put("obj", "normals.obj", obj + "vn 0 0 1\nvt 0 0\n" + "".join(f"f {a+1}/1/1 {b+1}/1/1 {c+1}/1/1\n" for a, b, c in F))
put("obj", "negative-quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\ng g\nusemtl m\ns 1\nf -4//1 -3//1 -2//1 -1//1\n")
put("obj", "cloud.obj", obj)

off_v = "".join(f"{x} {y} {z}\n" for x, y, z in V)
off_f = "".join(f"3 {a} {b} {c}\n" for a, b, c in F)
put("off", "plain.off", f"OFF\n# cut from tests/data/fandisk.ply\n{len(V)} {len(F)} 0\n" + off_v + off_f)
put("off", "noff.off", f"NOFF\n{len(V)} {len(F)} 0\n" + "".join(f"{x} {y} {z} 0 0 1\n" for x, y, z in V) + off_f)
put("off", "coff-quad.off", "COFF\n4 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n1 1 0 0 0 255 255\n0 1 0 1 1 1 255\n4 0 1 2 3 1 0 0\n")
put("off", "header-counts-one-line.off", f"OFF {len(V)} 0 0\n" + off_v)

put("xyz", "plain.xyz", "".join(f"{x} {y} {z}\n" for x, y, z in V))
put("xyz", "normals-commas-comments.xyz", "# x, y, z, nx, ny, nz\n\n" + "".join(f"{x},{y},{z},0,0,1\n" for x, y, z in V))



def pcd_header(fields, sizes, types, counts, width, height, data, viewpoint="0 0 0 1 0 0 0"):
    return (f"# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {fields}\nSIZE {sizes}\nTYPE {types}\n"
            f"COUNT {counts}\nWIDTH {width}\nHEIGHT {height}\nVIEWPOINT {viewpoint}\nPOINTS {width * height}\nDATA {data}\n")


def lzf_literals(raw):
    return b"".join(bytes([len(raw[i:i + 32]) - 1]) + raw[i:i + 32] for i in range(0, len(raw), 32))


xyzn = "x y z normal_x normal_y normal_z"
put("pcd", "ascii.pcd", pcd_header(xyzn, "4 4 4 4 4 4", "F F F F F F", "1 1 1 1 1 1", len(V), 1, "ascii")
    + "".join(" ".join(map(str, v + N[i])) + "\n" for i, v in enumerate(V)))
put("pcd", "binary-double.pcd", pcd_header("x y z", "8 8 8", "F F F", "1 1 1", len(V), 1, "binary").encode()
    + b"".join(struct.pack("<3d", *v) for v in V))
# Other fields around the coordinates, of every type, a padding field and a descriptor of 4 values.
odd = pcd_header("rgb z _ x intensity y fpfh", "4 4 1 8 2 4 4", "U F U F I F F", "1 1 3 1 1 1 4", len(V), 1, "binary").encode()
put("pcd", "binary-fields.pcd", odd + b"".join(struct.pack("<If3xdhf4f", 0xff8000, v[2], v[0], -7, v[1], 1, 2, 3, 4) for v in V))
columns = b"".join(struct.pack(f"<{len(V)}f", *(v[k] for v in V)) for k in range(3))
put("pcd", "binary-compressed-literals.pcd", pcd_header("x y z", "4 4 4", "F F F", "1 1 1", len(V), 1, "binary_compressed").encode()
    + struct.pack("<II", len(lzf_literals(columns)), len(columns)) + lzf_literals(columns))
put("pcd", "pcl-binary-compressed.pcd", (data / "pcd/plane_normals_binary_compressed.pcd").read_bytes())
put("pcd", "pcl-binary-padded.pcd", (data / "pcd/plane_normals_binary.pcd").read_bytes())
nan = float("nan")
grid = [V[0], (nan, nan, nan), V[1], V[2], (nan, nan, nan), V[3]]
put("pcd", "organized-nan.pcd", pcd_header("x y z", "4 4 4", "F F F", "1 1 1", 3, 2, "binary", "1 2 3 0.5 0.5 0.5 0.5").encode()
    + b"".join(struct.pack("<3f", *v) for v in grid))
put("pcd", "organized-nan-ascii.pcd", pcd_header("x y z", "4 4 4", "F F F", "1 1 1", 3, 2, "ascii")
    + "".join(" ".join(map(str, v)) + "\n" for v in grid))
put("pcd", "version-5-columns.pcd", "COLUMNS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n")
put("xyz", "scanner.asc", "".join(f"{x} {y} {z}\n" for x, y, z in V))

for broken in sorted((data / "broken").iterdir()):
    put(broken.suffix[1:], "broken-" + broken.name, broken.read_bytes())

# --- JSON files: config/ and its samples ---------------------------------------------------------
machine = json.loads((root / "config/machine.json").read_text())
plate = json.loads((root / "config/plate.json").read_text())
corners = json.loads((root / "config/samples/case3_block.corners.json").read_text())
cmmd = json.loads((root / "config/cmmd.json").read_text())
demo_sim = json.loads((root / "config/samples/demo_sim.json").read_text())
put("machine", "machine.json", (root / "config/machine.json").read_bytes())
put("plate", "plate.json", (root / "config/plate.json").read_bytes())
put("plate", "hole-fiducial.json", json.dumps(dict(plate, fiducial={"kind": "hole", "corner": 2, "diameter_mm": 6, "offset_mm": [10, 10]})))
put("registration", "case3_block.corners.json", (root / "config/samples/case3_block.corners.json").read_bytes())
inline = dict(corners, plate=plate)
put("registration", "inline-plate.json", json.dumps(inline))
put("registration", "no-plate-scan-up.json", json.dumps({"corners": corners["corners"], "noise_scan_mm": 0.02,
                                                         "noise_machine_mm": 0.005, "scan_up": [0, 0, 1]}))
put("daemon_config", "cmmd.json", (root / "config/cmmd.json").read_bytes())
put("daemon_config", "demo-sim.json", json.dumps(dict(cmmd, machine=demo_sim)))
put("daemon_config", "modbus.json", json.dumps(dict(cmmd, machine={"driver": "modbus", "transport": "rtu", "device": "/tmp/ttyX", "baud": 115200, "parity": "E", "heartbeat_s": 0.5})))
put("daemon_config", "grbl-tokens.json", json.dumps(dict(cmmd, machine={"driver": "serial", "device": "/tmp/ttyACM0", "baud": 115200},
    server=dict(cmmd["server"], tcp_bind="0.0.0.0", tokens=[{"token": "0123456789abcdef", "role": "operator"}]),
    machine_description=machine, plate=plate)))
put("daemon_config", "ippdme.json", json.dumps(dict(cmmd, machine={"driver": "ippdme", "host": "10.0.0.7", "port": 1294,
    "tool": "Probe_A", "tools": {"T1": "Probe_A"}, "timeouts": {"connect_s": 2, "response_s": 2, "motion_s": 600},
    "move_report_s": 0.1, "protocol_log": "ippdme.log", "machine": machine})))

# --- job requests and JSON-RPC lines after docs/api.md --------------------------------------------
given = {"corners": corners["corners"], "plate": plate}
measure = {"measure_plate": {"scan_corners": [{"id": c["id"], "scan": c["scan"]} for c in corners["corners"]],
                             "rough_machine": [{"id": c["id"], "machine": c["machine"]} for c in corners["corners"]]}}
submit = {"model": "sha256:" + "0" * 64, "name": "case3", "scale": 1, "delta_mm": 0.2, "spacing_mm": 2,
          "feature_angle_deg": 30, "seed": 1, "registration": given}
put("job_request", "given.json", json.dumps(submit))
put("job_request", "measure-plate.json", json.dumps(dict(submit, model="file:part.stl", registration=measure)))
put("job_request", "preview.json", json.dumps({"model": "file:part.ply"}))
put("job_request", "raw-scan.json", json.dumps(dict(submit, model="sha256:" + "0" * 64 + ".pcd", tolerance_mm=0.05,
                                                    bin_size_mm=0.2, adaptive=True)))

tolerances = {"edge_profile_mm": 0.05, "hole_diameter_mm": [-0.02, 0.03], "hole_position_mm": 0.1,
              "coverage_factor": 2, "machine_uncertainty_mm": 0.002,
              "edge_points": {"17": 0.01}, "curves": {"2": 0.2},
              "holes": {"0": {"diameter_mm": [-0.01, 0.01], "position_mm": 0.05}}}
put("job_request", "inspection.json", json.dumps(dict(submit, nominal={"model": "file:part-cad.stl", "scale": 1,
                                                                      "placement": "fit"}, tolerances=tolerances)))
put("job_request", "inspection-bad.json", json.dumps(dict(submit, nominal={"model": "http://x", "scale": 1e9,
    "placement": "guess"}, tolerances={"edge_profile_mm": 1e400, "hole_diameter_mm": [0.1, -0.1],
                                       "edge_points": {"4294967297": 0.1, "-1": 0.1, "x": 0.1},
                                       "holes": {"1": {"diameter_mm": "wide"}}})).replace("Infinity", "1e400"))


def rpc(method, params=None, id=1):
    message = {"jsonrpc": "2.0", "method": method, "id": id}
    if params is not None:
        message["params"] = params
    return json.dumps(message)


session = [
    rpc("server.info"),
    rpc("server.auth", {"token": "operator-token-0123456789"}, 2),
    rpc("server.subscribe", {"topics": ["job", "machine"]}, 3),
    rpc("machine.status", None, "s"),
    rpc("model.upload", {"name": "part.stl", "size": 3, "sha256": "a" * 64, "offset": 0, "data": "YWJj"}, 4),
    rpc("job.submit", submit, 5),
    rpc("plan.preview", {"model": "file:part.ply"}, 6),
    rpc("registration.fit", {"corners": corners["corners"]}, 7),
    rpc("job.get", {"job": 1}, 8),
    rpc("job.resume", {"job": 1, "reregister": True}, 9),
    rpc("job.result", {"job": 1, "format": "csv"}, None),
    json.dumps({"jsonrpc": "2.0", "method": "machine.stop"}),
]
put("json_rpc", "session.jsonl", "\n".join(session) + "\n")
put("json_rpc", "crlf-blank-lines.jsonl", "\r\n\r\n  \t\r\n".join(session[:3]) + "\r\n" + session[3])
put("json_rpc", "batch.jsonl", json.dumps([json.loads(session[1]), json.loads(session[8]),
                                           {"jsonrpc": "2.0", "method": "job.list"}, 1, {"foo": "boo"}]) + "\n[]\n")
put("json_rpc", "observer.jsonl", rpc("server.auth", {"token": "observer-token-0123456789"}) + "\n" +
    rpc("machine.home") + "\n" + rpc("fuzz.nonstandard") + "\n")
put("json_rpc", "invalid.jsonl", '{"jsonrpc": "2.0", "method": "foobar, "params": "bar", "baz]\n'
    '{"jsonrpc": "2.0", "method": 1, "params": "bar"}\n{"jsonrpc": "1.0", "method": "server.info", "id": {}}\n'
    '[1e400]\n' + "[" * 200 + "]" * 200 + "\n")
put("job_request", "rpc-line.json", session[5])
put("json_rpc", "operator-view.jsonl", "\n".join([
    rpc("server.auth", {"token": "operator-token-0123456789"}),
    rpc("server.dashboard", None, 2),
    rpc("machine.jog", {"direction": [1, 0, 0], "speed_mm_s": 2, "hold_s": 0.3}, 3),
    rpc("machine.jog", {"direction": [0, 3, -4], "distance_mm": 5}, 4),
    rpc("machine.jog", {"direction": [0, 0, 0], "speed_mm_s": 1e9, "distance_mm": -1}, 5),
    rpc("machine.jog_stop", None, 6),
    rpc("job.view", {"job": 1}, 7),
    rpc("job.report", {"job": 4294967297}, 8),
    rpc("job.result", {"job": 1, "format": "qif"}, 9),
    rpc("job.submit", dict(submit, tolerances=tolerances), 10),
]) + "\n")

# --- Grbl replies (docs/hal.md) and Modbus register blocks (docs/modbus-map.md) -------------------
put("grbl", "replies.txt", "Grbl 1.1h ['$' for help]\r\nok\r\n<Idle|MPos:0.000000,0.000000,0.000000|FS:0,0|T:0.000000>\r\n"
    "<Hold:0|MPos:1.5,-2.25,60|FS:1200,0|Pn:PZ|T:12.5>\r\n<Run|MPos:10,20,30|F:600|Bf:15,128|Ln:3|WCO:0,0,0>\r\n"
    "[PRB:100.123456,200.5,-3.25:1]\r\n[PRB:0,0,0:0]\r\nerror:9\r\nerror:15\r\nALARM:1\r\nALARM:3\r\nALARM:5\r\n"
    "[MSG:Reset to continue]\r\n$10=1\n")
put("grbl", "alarm-states.txt", "<Alarm|MPos:0,0,0|FS:0,0|Pn:R>\n<Door:1|MPos:0,0,0>\nerror:20\nerror:33\nALARM:9\n")

# --- I++ DME lines, both directions (docs/ippdme.md): what a client sends, what a server answers ---
put("ippdme", "session.txt", "00001 StartSession()\r\n00002 GetDMEVersion()\r\n00003 EnumTools()\r\n"
    "00004 ChangeTool(\"T1\")\r\n00005 SetCoordSystem(MachineCsy)\r\n"
    "00006 OnPtMeasReport(X(), Y(), Z(), IJK(), ER(), Clock())\r\n"
    "00007 SetProp(Tool.PtMeasPar.Speed(5), Tool.PtMeasPar.Approach(2.5), Tool.GoToPar.Speed(200))\r\n"
    "00008 GetProp(Tool.PtMeasPar.Search())\r\nE0001 OnMoveReportE(Time(0.05), Dis(0.5), X(), Y(), Z())\r\n"
    "00009 GoTo(X(300.000000000), Y(400), Z(-1.5e1))\r\n00010 PtMeas(X(1), Y(2), Z(3), IJK(0, 0, 1))\r\n"
    "E0002 AbortE()\r\n00011 ClearAllErrors()\r\n00012 Get(X(), Y(), Z())\r\n00013 EndSession()\r\n")
put("ippdme", "replies.txt", "00001 &\r\n00002 # DMEVersion(\"1.4.3\")\r\n00002 %\r\n00003 # \"T1\"\r\n"
    "00010 # ER(1.000000000), IJK(0, 0, 1), Z(41.000123), X(278), Y(353)\r\nE0001 # X(1), Y(2), Z(3), Clock(6.25)\r\n"
    "00007 ! Error(1, 0504, SetProp, \"clamped to 20\")\r\nE0000 ! Error(3, 0500, \"\", \"Emergency stop\")\r\n"
    "00010 ! Error(2, 1003, PtMeas, \"No touch\")\r\n")
put("ippdme", "broken.txt", "0001 Home()\r\n00001Home()\r\n00001 Home(\r\n00001 Get(X(X(X(X(\r\n00001 ChangeTool(\"T1)\r\n"
    "00001 # X(1e999)\r\n00001 ! Error(2, 99999, GoTo, \"x\")\r\n00001 ! Error(2.5, 1, a, \"b\")\r\n\x01\x7f\r\n")


def regs(*values):
    return b"".join(struct.pack(">H", v & 0xFFFF) for v in values)


def u32(v):
    return [(v >> 16) & 0xFFFF, v & 0xFFFF]


status = [1, 0b1, 0, 7, 0] + u32(100_000_000) + u32(-2_000_000 & 0xFFFFFFFF) + u32(60_000_000) + u32(123_456) + [1, 1] \
    + u32(100_500_000) + u32(200_000_000) + u32(-3_250_000 & 0xFFFFFFFF) + u32(4_321_000) + u32(120_000)
tip = [0x5431, 0, 0, 0] + u32(999_800) + u32(4000) + u32(0) + u32(-2000 & 0xFFFFFFFF) + u32(1_764_000_000) + u32(300) + [25]
text = [int.from_bytes(b"Ea", "big"), int.from_bytes(b"rl", "big"), int.from_bytes(b"y!", "big"), 0]
put("modbus_status", "status-tip-text.bin", regs(*status, *tip, *text))
put("modbus_status", "fault.bin", regs(0, 0b101101, 8, 3, 8, *([0] * 20), *tip))
put("modbus_status", "short.bin", regs(1, 2, 3))

# --- HTTP requests to the dashboard (docs/api.md, Dashboard transport) ----------------------------
def request(target, *headers, method="GET", version="1.1"):
    return f"{method} {target} HTTP/{version}\r\n" + "".join(h + "\r\n" for h in headers) + "\r\n"


upgrade = ("Connection: Upgrade", "Upgrade: websocket", "Sec-WebSocket-Version: 13",
           "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==")
put("http_request", "pages.txt", request("/", "Host: 127.0.0.1:8080") + request("/static/app.js", "Host: localhost:8080")
    + request("/lib/three/build/three.module.js", "Host: [::1]:8080", method="HEAD")
    + request("/jobs/12/report?token=abc%20def", "Host: 10.1.2.3:8080"))
put("http_request", "websocket.txt", request("/rpc", "Host: 127.0.0.1:8080", "Origin: http://127.0.0.1:8080", *upgrade)
    + request("/rpc", "Host: cmm-station-3.example", "Origin: https://cmm-station-3.example", *upgrade))
put("http_request", "hostile.txt", request("/static/..%2f..%2fetc/passwd", "Host: 127.0.0.1:8080")
    + request("/static/%2e%2e/%2E%2E/cmmd.json", "Host: 127.0.0.1:8080") + request("/static/%00", "Host: localhost:8080")
    + request("/jobs/-1/report", "Host: localhost:8080") + request("/jobs/99999999999/report", "Host: localhost:8080")
    + request("/rpc", "Host: attacker.example:8080", "Origin: http://attacker.example:8080", *upgrade)
    + request("/rpc", "Host: 127.0.0.1:8080", "Origin: null", *upgrade)
    + request("/", "Host: 127.0.0.1:8080", "Content-Length: 5", method="POST") + "hello"
    + request("//lib/three/../../../", "Host: 127.0.0.1:8080", version="1.0"))
print("seeds written under", corpus)

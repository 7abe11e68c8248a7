// The 3-D view of a job (three.js r111, Debian's libjs-three): the reference mesh from job.view's
// PLY, the planned edge points coloured by method or by why they are not probeable, the bores'
// rims, the touches as they are made, and after the job the measured points coloured by deviation.
// Everything is in the scan frame S; a touch's ball centre comes in M and is mapped by T_M_S⁻¹.
// Drawn on demand (a change, an orbit), with the drawing buffer kept so the page can be read back.
import * as THREE from '/lib/three/build/three.module.js';
import {OrbitControls} from '/lib/three/examples/jsm/controls/OrbitControls.js';
import {PLYLoader} from '/lib/three/examples/jsm/loaders/PLYLoader.js';
import {bytes_of_base64} from './upload.js';
import {METHOD_COLOURS, NOT_MEASURED, REASON_PALETTE, VERDICT_COLOURS, edge_deviation} from './colours.js';

export const BACKGROUND = 0xf3f5f7;

function points_object(capacity, size_px) {
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(capacity * 3), 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(new Float32Array(capacity * 3), 3));
  geometry.setDrawRange(0, 0);
  const material = new THREE.PointsMaterial({size: size_px, sizeAttenuation: false, vertexColors: THREE.VertexColors});
  const points = new THREE.Points(geometry, material);
  points.frustumCulled = false;
  points.userData.items = [];
  return points;
}

// Fills a points object with [{position, colour (0-255 RGB), item}].
function fill_points(points, entries) {
  let geometry = points.geometry;
  if (geometry.attributes.position.count < entries.length) {
    points.geometry.dispose();
    const fresh = points_object(entries.length, 1);
    points.geometry = geometry = fresh.geometry;
  }
  const p = geometry.attributes.position.array, c = geometry.attributes.color.array;
  entries.forEach((e, i) => {
    p.set(e.position, i * 3);
    c.set(e.colour.map((x) => x / 255), i * 3);
  });
  geometry.attributes.position.needsUpdate = true;
  geometry.attributes.color.needsUpdate = true;
  geometry.setDrawRange(0, entries.length);
  geometry.computeBoundingSphere();
  points.userData.items = entries.map((e) => e.item);
}

// Groups the reasons a point is not probeable by their words, numbers left out: "edge point 12:
// two touches in the window are blocked" and "... 13: ..." are one group.
export function reason_group(reason) {
  if (!reason) return 'no reason given';
  const words = reason.replace(/\b(touch|point|edge point|hole)\s+\d+\b/g, '$1').replace(/-?\d+(\.\d+)?/g, '#');
  return words.length > 70 ? `${words.slice(0, 67)}…` : words;
}

export class JobView3D {
  constructor(container, on_pick) {
    this.container = container;
    this.on_pick = on_pick;
    this.renderer = new THREE.WebGLRenderer({antialias: true, preserveDrawingBuffer: true});
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.setClearColor(BACKGROUND, 1);
    container.append(this.renderer.domElement);
    // The scale bar: the view fits any part to the canvas, so without it a part 25.4× too small
    // (a model in inches) looks like any other.
    this.scale_bar = document.createElement('div');
    this.scale_bar.className = 'scale-bar';
    this.scale_bar.innerHTML = '<span class="scale-bar-line"></span><span class="scale-bar-label"></span>';
    container.append(this.scale_bar);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(35, 1, 0.1, 10000);
    this.camera.up.set(0, 0, 1);
    this.camera.position.set(200, -250, 200);
    this.scene.add(new THREE.AmbientLight(0xffffff, 0.45));
    const light = new THREE.DirectionalLight(0xffffff, 0.6);
    light.position.set(0.3, -0.4, 1);
    this.camera.add(light);
    this.scene.add(this.camera);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => this.request_render(0));

    this.mesh = null;
    this.mesh_key = null;
    this.planned = points_object(1024, 5);
    this.touches = points_object(1024, 4);
    this.measured = points_object(1024, 7);
    this.holes = new THREE.Group();
    this.scene.add(this.planned, this.touches, this.measured, this.holes);
    this.touch_entries = [];
    this.colour_by = 'method';
    this.view = null;
    this.last_info = {points: 0, triangles: 0, calls: 0};

    this.raycaster = new THREE.Raycaster();
    const down = {x: 0, y: 0};
    this.renderer.domElement.addEventListener('pointerdown', (e) => { down.x = e.clientX; down.y = e.clientY; });
    this.renderer.domElement.addEventListener('pointerup', (e) => {
      if (Math.hypot(e.clientX - down.x, e.clientY - down.y) < 4) this.pick(e);  // a click, not an orbit
    });
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  resize() {
    const w = Math.max(1, this.container.clientWidth), h = Math.max(1, this.container.clientHeight);
    const size = this.renderer.getSize(new THREE.Vector2());
    if (size.x === w && size.y === h && this.camera.aspect === w / h) return;
    this.renderer.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.request_render(0);
  }

  render() {
    const start = performance.now();
    this.renderer.render(this.scene, this.camera);
    this.update_scale_bar();
    const r = this.renderer.info.render;
    this.last_info = {points: r.points, triangles: r.triangles, calls: r.calls};
    this.last_render_at = performance.now();
    this.render_ms = this.last_render_at - start;
  }

  // A round length in mm (1, 2 or 5 × 10ⁿ) about 100 px long at the orbit target's depth, redrawn
  // with every frame, so it stays right whatever the auto-fit, the zoom or the canvas's size do.
  update_scale_bar() {
    const height_px = this.renderer.getSize(new THREE.Vector2()).y;
    const depth = this.camera.position.distanceTo(this.controls.target);
    const px_per_mm = height_px / (2 * depth * Math.tan((this.camera.fov * Math.PI) / 360));
    if (!(px_per_mm > 0) || !Number.isFinite(px_per_mm)) return;
    const wanted_mm = 100 / px_per_mm;
    const decade = Math.pow(10, Math.floor(Math.log10(wanted_mm)));
    const mm = [5, 2, 1].map((k) => k * decade).find((v) => v <= wanted_mm);
    this.scale_bar.dataset.mm = String(mm);
    this.scale_bar.querySelector('.scale-bar-line').style.width = `${(mm * px_per_mm).toFixed(1)}px`;
    this.scale_bar.querySelector('.scale-bar-label').textContent = `${Number(mm.toPrecision(3))} mm`;
  }

  // One frame for any number of changes: touches arrive faster than a software-rendered frame
  // (SwiftShader, a station PC without a GPU) is drawn, and a frame per touch would starve the page.
  // Data changes are drawn at most every `gap_ms` plus a frame's own time.
  request_render(gap_ms = 200) {
    if (this.render_pending) return;
    this.render_pending = true;
    const wait = Math.max(0, (this.last_render_at || 0) + gap_ms + (this.render_ms || 0) - performance.now());
    setTimeout(() => requestAnimationFrame(() => {
      this.render_pending = false;
      this.render();
    }), wait);
  }

  // What the last frame drew, and what the view holds: for the page's own checks and the tests.
  stats() {
    return {
      ...this.last_info,
      render_ms: this.render_ms,
      pending: !!this.render_pending,  // a change not drawn yet
      mesh_triangles: this.mesh ? this.mesh.geometry.index ? this.mesh.geometry.index.count / 3 : 0 : 0,
      planned: this.planned.geometry.drawRange.count,
      touches: this.touches.geometry.drawRange.count,
      measured: this.measured.geometry.drawRange.count,
    };
  }

  // job.view's answer: the mesh (parsed once per job), the plan, the touches made, the result;
  // `centres`: the ball centres (M) of the touches heard live, by touch id, drawn where they were.
  load(view, centres = new Map()) {
    this.view = view;
    this.inverse = null;
    if (view.T_M_S) {
      const m = new THREE.Matrix4();
      m.set(...view.T_M_S.flat());
      this.inverse = new THREE.Matrix4().getInverse(m);
    }
    const key = view.reference_ply ? `${view.job}:${view.reference_ply.length}` : null;
    if (key && key !== this.mesh_key) {
      if (this.mesh) {
        this.scene.remove(this.mesh);
        this.mesh.geometry.dispose();
      }
      const geometry = new PLYLoader().parse(bytes_of_base64(view.reference_ply).buffer);
      geometry.computeVertexNormals();
      const material = new THREE.MeshPhongMaterial({color: 0xb9c2cc, specular: 0x222222, shininess: 20,
                                                    side: THREE.DoubleSide, polygonOffset: true,
                                                    polygonOffsetFactor: 1, polygonOffsetUnits: 1});
      this.mesh = new THREE.Mesh(geometry, material);
      this.scene.add(this.mesh);
      this.mesh_key = key;
      this.fit();
    }
    this.touch_of = new Map();  // touch id → what it measures
    for (const p of view.edge_points) for (const t of p.touches) this.touch_of.set(t, {position: p.position_S, kind: 'edge point', id: p.id});
    for (const h of view.holes) for (const t of h.touches) this.touch_of.set(t, {position: h.centre_S, kind: 'hole', id: h.id});
    this.touch_entries = [];
    this.touched = new Set();
    for (const t of view.touches_done) this.add_touch(t, centres.get(t) || null, false);
    for (const [t, centre] of centres) this.add_touch(t, centre, false);
    fill_points(this.touches, this.touch_entries);
    this.draw_holes();
    this.draw_features();
    this.request_render(0);
  }

  fit() {
    const sphere = this.mesh.geometry.boundingSphere || (this.mesh.geometry.computeBoundingSphere(), this.mesh.geometry.boundingSphere);
    const c = sphere.center, r = Math.max(1, sphere.radius);
    this.controls.target.copy(c);
    const distance = r / Math.sin((this.camera.fov * Math.PI) / 360) * 1.05;
    this.camera.position.copy(c).add(new THREE.Vector3(0.55, -0.75, 0.65).normalize().multiplyScalar(distance));
    this.camera.near = distance / 100;
    this.camera.far = distance * 10;
    this.camera.updateProjectionMatrix();
    this.controls.update();
  }

  // A touch made (job.touch: its id and, live, the ball centre in M): the centre mapped into S when
  // T_M_S is known, else the planned point of the feature it measures. Returns false for one already shown.
  add_touch(touch, centre_M, redraw = true) {
    if (this.touched.has(touch)) return false;
    this.touched.add(touch);
    let position = null;
    if (centre_M && this.inverse) position = new THREE.Vector3(...centre_M).applyMatrix4(this.inverse).toArray();
    else if (this.touch_of && this.touch_of.has(touch)) position = this.touch_of.get(touch).position;
    if (position) {
      this.touch_entries.push({position, colour: [230, 85, 13], item: {touch, ...(this.touch_of.get(touch) || {})}});
      if (redraw) {
        fill_points(this.touches, this.touch_entries);
        this.request_render();
      }
    }
    return true;
  }

  touch_count() { return this.touched ? this.touched.size : 0; }

  set_colour_by(mode) {
    this.colour_by = mode;
    if (this.view) {
      this.draw_features();
      this.request_render(0);
    }
  }

  draw_holes() {
    for (const child of [...this.holes.children]) {
      this.holes.remove(child);
      child.geometry.dispose();
      child.material.dispose();
    }
    const result = this.view.result;
    for (const h of this.view.holes) {
      const axis = new THREE.Vector3(...h.axis_S).normalize();
      const u = new THREE.Vector3(1, 0, 0).cross(axis);
      if (u.length() < 0.1) u.set(0, 1, 0).cross(axis);
      u.normalize();
      const v = axis.clone().cross(u);
      const ring = [];
      for (let i = 0; i < 64; ++i) {
        const a = (i / 64) * 2 * Math.PI;
        ring.push(new THREE.Vector3(...h.centre_S).addScaledVector(u, h.radius * Math.cos(a)).addScaledVector(v, h.radius * Math.sin(a)));
      }
      let colour = h.touches.length ? [31, 119, 180] : NOT_MEASURED;
      const r = result && result.holes.find((x) => x.id === h.id);
      if (r && r.inspection && r.inspection.verdict) colour = VERDICT_COLOURS[r.inspection.verdict] || NOT_MEASURED;
      else if (r) colour = r.status === 'measured' ? [40, 170, 70] : NOT_MEASURED;
      const line = new THREE.LineLoop(new THREE.BufferGeometry().setFromPoints(ring),
                                      new THREE.LineBasicMaterial({color: new THREE.Color(...colour.map((x) => x / 255))}));
      line.userData.hole = h.id;
      this.holes.add(line);
    }
  }

  // The planned points by method or reason; after the job the measured ones by deviation instead.
  // Returns the legend: [{label, colour, count}] and what it is of.
  draw_features() {
    const view = this.view;
    const planned = [], measured = [];
    const result = view.result;
    const inspected = !!(result && result.inspection);
    const reasons = new Map();
    if (this.colour_by === 'reason')
      for (const p of view.edge_points) if (!p.probeable) {
        const g = reason_group(p.reason);
        reasons.set(g, (reasons.get(g) || 0) + 1);
      }
    const groups = [...reasons.entries()].sort((a, b) => b[1] - a[1]);
    const group_colour = new Map(groups.map(([g], i) => [g, i < REASON_PALETTE.length ? REASON_PALETTE[i] : NOT_MEASURED]));
    view.edge_points.forEach((p, i) => {
      const r = result ? result.edge_points[i] : null;
      const item = {planned: p, result: r};
      const d = r ? edge_deviation(r, inspected) : null;
      if (d && r.measured_S) {
        measured.push({position: r.measured_S.position, colour: d.colour, item, order: Math.abs(d.value)});
        return;
      }
      let colour = METHOD_COLOURS[p.method] || NOT_MEASURED;
      if (result) colour = NOT_MEASURED;
      else if (this.colour_by === 'reason') colour = p.probeable ? [200, 210, 220] : group_colour.get(reason_group(p.reason));
      planned.push({position: p.position_S, colour, item});
    });
    measured.sort((a, b) => a.order - b.order);  // the largest deviations drawn last, on top
    fill_points(this.planned, planned);
    fill_points(this.measured, measured);
    this.touches.visible = !result;  // once measured, the points say more than the touches that made them
    this.planned.material.size = result ? 3 : 5;
    this.legend_groups = groups;
  }

  pick(event) {
    this.resize();
    const rect = this.renderer.domElement.getBoundingClientRect();
    const mouse = new THREE.Vector2(((event.clientX - rect.left) / rect.width) * 2 - 1, -((event.clientY - rect.top) / rect.height) * 2 + 1);
    this.raycaster.setFromCamera(mouse, this.camera);
    const scale = this.mesh ? this.mesh.geometry.boundingSphere.radius : 50;
    this.raycaster.params.Points.threshold = scale / 150;
    let hits = this.raycaster.intersectObjects([this.measured, this.planned, this.touches].filter((o) => o.visible));
    // A points object's unused capacity sits at the origin, and r111's raycast ignores the draw range.
    hits = hits.filter((h) => h.index < h.object.userData.items.length);
    if (!hits.length) return;
    // Nearest to the ray first, then nearest to the eye: a click means the dot under the cursor.
    hits.sort((a, b) => a.distanceToRay - b.distanceToRay || a.distance - b.distance);
    const hit = hits[0];
    this.on_pick(hit.object.userData.items[hit.index], hit.object === this.touches ? 'touch' : 'point');
  }

  // Where the i-th measured point (in drawing order) is on the canvas, CSS pixels from its top left.
  screen_position(i) {
    this.resize();  // the layout may have changed since the last ResizeObserver callback
    const p = this.measured.geometry.attributes.position.array;
    const v = new THREE.Vector3(p[i * 3], p[i * 3 + 1], p[i * 3 + 2]).project(this.camera);
    const canvas = this.renderer.domElement;
    return {x: ((v.x + 1) / 2) * canvas.clientWidth, y: ((1 - v.y) / 2) * canvas.clientHeight, index: i};
  }

  // The measured point drawn nearest the canvas's centre (for a test's click), or null.
  central_measured_point() {
    const canvas = this.renderer.domElement;
    let best = null;
    for (let i = 0; i < this.measured.geometry.drawRange.count; ++i) {
      const s = this.screen_position(i);
      s.off = Math.hypot(s.x - canvas.clientWidth / 2, s.y - canvas.clientHeight / 2);
      if (!best || s.off < best.off) best = s;
    }
    return best;
  }

  // The WebGL canvas's pixels that are not the background (the page's read-back for tests).
  painted_pixels() {
    const canvas = this.renderer.domElement;
    const copy = document.createElement('canvas');
    copy.width = canvas.width;
    copy.height = canvas.height;
    const g = copy.getContext('2d');
    g.drawImage(canvas, 0, 0);
    const data = g.getImageData(0, 0, copy.width, copy.height).data;
    const bg = new THREE.Color(BACKGROUND);
    const [br, bgg, bb] = [bg.r * 255, bg.g * 255, bg.b * 255].map(Math.round);
    let painted = 0;
    for (let i = 0; i < data.length; i += 4)
      if (Math.abs(data[i] - br) + Math.abs(data[i + 1] - bgg) + Math.abs(data[i + 2] - bb) > 12) ++painted;
    return {painted, total: copy.width * copy.height};
  }
}

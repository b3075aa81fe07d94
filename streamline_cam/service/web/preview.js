// The 3-D preview: fitted surface, passes coloured by order, links, rapids, and the tool.
//
// Drawn from GET /jobs/{id}/preview, which decimates the toolpath for display (the G-code
// is never decimated). Rendering is on demand (a camera move, the slider), so a large
// toolpath costs nothing while nobody touches the view.

import * as THREE from "three";
import { OrbitControls } from "./vendor/three/OrbitControls.js";

/** Points asked of the preview endpoint: enough to show every pass, few enough to stay
 *  smooth in a software renderer (the endpoint keeps each pass's shape within its
 *  reported deviation). */
export const MAX_POINTS = 60000;

const BACKGROUND = 0xf3f5f7;
const LINK_COLOUR = 0xff8c00;
const RAPID_COLOUR = 0xd62728;
const TOOL_COLOUR = 0x7a5cc4;
const MACHINE_COLOUR = 0x1a9e55;

/** Colour of pass `k` of `n`: blue (first) through green to red (last). */
function passColour(k, n, target) {
  const f = n > 1 ? k / (n - 1) : 0;
  return target.setHSL(0.66 * (1 - f), 0.85, 0.45);
}

/** Every `stride`-th point of a flat xyz run, its last point kept. */
function thin(points, stride) {
  const n = points.length / 3;
  if (stride <= 1 || n <= 2) return points;
  const keep = [];
  for (let i = 0; i < n; i += stride) keep.push(i);
  if (keep[keep.length - 1] !== n - 1) keep.push(n - 1);
  const out = new Float32Array(3 * keep.length);
  keep.forEach((i, k) => {
    out[3 * k] = points[3 * i];
    out[3 * k + 1] = points[3 * i + 1];
    out[3 * k + 2] = points[3 * i + 2];
  });
  return out;
}

/** The segments with at most about `limit` points: a guard for a server that sent more
 *  than asked (display only; the G-code is never touched). */
export function capPoints(segments, limit) {
  let total = 0;
  for (const s of segments) total += s.points.length / 3;
  const stride = Math.ceil(total / limit);
  if (stride <= 1) return segments;
  return segments.map((s) => ({ ...s, points: thin(s.points, stride),
                                tool_axis: s.tool_axis && thin(s.tool_axis, stride) }));
}

/** `"ball:6"`, `"flat:10"`, `"bull:10:2"` -> {kind, radius_mm}; a ball of 6 mm otherwise. */
export function parseCutter(spec) {
  const [kind, diameter] = String(spec || "").split(":");
  const d = Number.parseFloat(diameter);
  return { kind: ["ball", "flat", "bull"].includes(kind) ? kind : "ball",
           radius_mm: Number.isFinite(d) && d > 0 ? d / 2 : 3 };
}

/** Triangles of a rows x cols grid of points (rows wrap round when `closed`). */
function gridIndex(rows, cols, closed) {
  const index = [];
  const last = closed ? cols : cols - 1;
  for (let r = 0; r + 1 < rows; r++) {
    for (let c = 0; c < last; c++) {
      const c1 = (c + 1) % cols;
      const a = r * cols + c, b = r * cols + c1, d = (r + 1) * cols + c, e = (r + 1) * cols + c1;
      index.push(a, b, e, a, e, d);
    }
  }
  return index;
}

/** Line pieces of runs of points, not indexed (dashed materials need that). */
function pieces(runs) {
  let n = 0;
  for (const p of runs) n += Math.max(0, p.length / 3 - 1);
  const out = new Float32Array(6 * n);
  let o = 0;
  for (const p of runs) {
    for (let i = 0; i + 5 < p.length; i += 3) {
      for (let k = 0; k < 6; k++) out[o++] = p[i + k];
    }
  }
  return out;
}

export class Preview {
  constructor(container, slider, readout) {
    this.container = container;
    // no multisampling: it doubles the cost of a frame in a software renderer (no GPU)
    this.slider = slider;
    this.readout = readout;
    this.renderer = new THREE.WebGLRenderer({ antialias: false });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.setClearColor(BACKGROUND);
    container.append(this.renderer.domElement);

    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.1, 1e5);
    this.camera.up.set(0, 0, 1);  // machine Z up
    this.scene.add(this.camera);
    this.scene.add(new THREE.AmbientLight(0xffffff, 1.1));
    const light = new THREE.DirectionalLight(0xffffff, 1.6);
    light.position.set(1, 2, 3);
    this.camera.add(light);  // the light follows the view

    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener("change", () => this.render());
    this.content = new THREE.Group();
    this.scene.add(this.content);
    this.tool = null;
    this.machineTool = null;
    this.track = null;

    slider.addEventListener("input", () => this.placeTool(Number(slider.value)));
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  resize() {
    const width = this.container.clientWidth || 1;
    const height = this.container.clientHeight || 1;
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  render() {
    if (this.pending) return;
    this.pending = requestAnimationFrame(() => {
      this.pending = 0;
      this.renderer.render(this.scene, this.camera);
    });
  }

  clear() {
    this.content.traverse((node) => {
      node.geometry?.dispose();
      node.material?.dispose();
    });
    this.content.clear();
    this.tool = this.machineTool = null;
    this.track = null;
    this.slider.max = 0;
    this.readout.textContent = "";
    this.container.dataset.state = "empty";
    this.render();
  }

  /** Draw a job's preview (`data`: the endpoint's answer, `job`: its view). */
  show(job, data) {
    this.clear();
    const cutter = parseCutter(job.parameters?.cutter);
    const { surface } = data;
    const segments = capPoints(data.segments, MAX_POINTS);
    if (surface && surface.rows > 1 && surface.cols > 1) this.addSurface(surface);

    const cuts = segments.filter((s) => s.kind === "cut");
    const passes = new Set(cuts.map((s) => s.pass ?? 0));
    const passOrder = [...passes].sort((a, b) => a - b);
    this.addCuts(cuts, passOrder);
    const links = segments.filter((s) => s.kind === "link").map((s) => s.points);
    const rapids = segments.filter((s) => s.kind === "rapid").map((s) => s.points);
    if (links.length) {
      this.addLines(pieces(links), new THREE.LineBasicMaterial({ color: LINK_COLOUR }), "links");
    }
    const box = new THREE.Box3().setFromObject(this.content);
    const size = box.getSize(new THREE.Vector3()).length() || 1;
    if (rapids.length) {
      const dashes = new THREE.LineDashedMaterial({ color: RAPID_COLOUR, dashSize: size / 80,
                                                    gapSize: size / 120 });
      this.addLines(pieces(rapids), dashes, "rapids").computeLineDistances();
    }
    this.addTool(cutter, size);
    this.setTrack(segments, data.five_axis);
    this.frame(box);
    this.container.dataset.state = "ready";
    this.container.dataset.points = String(this.track.points.length / 3);
    this.container.dataset.passes = String(passOrder.length);
    return { passes: passOrder.length, points: this.track.points.length / 3 };
  }

  addSurface({ rows, cols, points, closed }) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute("position", new THREE.Float32BufferAttribute(points, 3));
    geometry.setIndex(gridIndex(rows, cols, closed));
    geometry.computeVertexNormals();
    const material = new THREE.MeshPhongMaterial({
      color: 0xaab4be, side: THREE.DoubleSide, transparent: true, opacity: 0.6,
      polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1, shininess: 20 });
    const mesh = new THREE.Mesh(geometry, material);
    mesh.name = "surface";
    this.content.add(mesh);
  }

  /** All cutting passes as one indexed line set, each vertex coloured by its pass. */
  addCuts(cuts, passOrder) {
    let n = 0, pairs = 0;
    for (const s of cuts) {
      n += s.points.length / 3;
      pairs += Math.max(0, s.points.length / 3 - 1);
    }
    const positions = new Float32Array(3 * n);
    const colours = new Float32Array(3 * n);
    const index = new Uint32Array(2 * pairs);
    const rank = new Map(passOrder.map((p, i) => [p, i]));
    const colour = new THREE.Color();
    let v = 0, o = 0;
    for (const s of cuts) {
      positions.set(s.points, 3 * v);
      passColour(rank.get(s.pass ?? 0), passOrder.length, colour);
      const count = s.points.length / 3;
      for (let i = 0; i < count; i++) colour.toArray(colours, 3 * (v + i));
      for (let i = 0; i + 1 < count; i++) {
        index[o++] = v + i;
        index[o++] = v + i + 1;
      }
      v += count;
    }
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute("position", new THREE.BufferAttribute(positions, 3));
    geometry.setAttribute("color", new THREE.BufferAttribute(colours, 3));
    geometry.setIndex(new THREE.BufferAttribute(index, 1));
    const lines = new THREE.LineSegments(geometry,
                                         new THREE.LineBasicMaterial({ vertexColors: true }));
    lines.name = "passes";
    this.content.add(lines);
  }

  addLines(positions, material, name) {
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute("position", new THREE.BufferAttribute(positions, 3));
    const lines = new THREE.LineSegments(geometry, material);
    lines.name = name;
    this.content.add(lines);
    return lines;
  }

  /** The cutter (ball or flat end and its shank) and its axis, tip at the origin, axis +Y. */
  makeTool({ kind, radius_mm }, size, colour, name) {
    const tool = new THREE.Group();
    tool.name = name;
    const material = new THREE.MeshPhongMaterial({ color: colour, transparent: true,
                                                   opacity: 0.75 });
    const length = 6 * radius_mm;
    const base = kind === "ball" ? radius_mm : 0;
    const shank = new THREE.Mesh(new THREE.CylinderGeometry(radius_mm, radius_mm, length, 24),
                                 material);
    shank.position.y = base + length / 2;
    tool.add(shank);
    if (kind === "ball") {
      const ball = new THREE.Mesh(new THREE.SphereGeometry(radius_mm, 24, 12), material);
      ball.position.y = radius_mm;
      tool.add(ball);
    }
    const reach = base + length + Math.max(size / 8, 4 * radius_mm);
    const axis = new THREE.BufferGeometry().setFromPoints(
      [new THREE.Vector3(0, -2 * radius_mm, 0), new THREE.Vector3(0, reach, 0)]);
    tool.add(new THREE.Line(axis, new THREE.LineBasicMaterial({ color: 0x222222 })));
    this.content.add(tool);
    return tool;
  }

  addTool(cutter, size) {
    this.tool = this.makeTool(cutter, size, TOOL_COLOUR, "tool");
    this.machineTool = this.makeTool(cutter, size, MACHINE_COLOUR, "machine");
    this.machineTool.visible = false;
    this.machineTool.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0),
                                                   new THREE.Vector3(0, 0, 1));
  }

  /** The machine's tool at `position` ({x, y, z}, the program's coordinates, which are the
   *  preview's on a 3-axis machine), or hidden (null). */
  showMachine(position) {
    if (!this.machineTool) return;
    this.machineTool.visible = Boolean(position);
    if (position) this.machineTool.position.set(position.x, position.y, position.z);
    this.container.dataset.machine = position ? "shown" : "";
    this.render();
  }

  /** The points the slider walks, in program order, with their tool axes. */
  setTrack(segments, fiveAxis) {
    let n = 0;
    for (const s of segments) n += s.points.length / 3;
    const points = new Float32Array(3 * n);
    const axes = fiveAxis ? new Float32Array(3 * n) : null;
    const kinds = new Array(n);
    let v = 0;
    for (const s of segments) {
      points.set(s.points, 3 * v);
      if (axes) {
        if (s.tool_axis) {
          axes.set(s.tool_axis, 3 * v);
        } else {
          for (let i = 0; i < s.points.length; i += 3) axes[3 * v + i + 2] = 1;
        }
      }
      kinds.fill(s.kind === "cut" ? `pass ${s.pass ?? 0}` : s.kind, v, v + s.points.length / 3);
      v += s.points.length / 3;
    }
    this.track = { points, axes, kinds };
    this.slider.max = Math.max(0, n - 1);
    this.slider.value = 0;
    this.placeTool(0);
  }

  /** Put the tool's tip on track point `i`, along its axis (Z on a 3-axis path). */
  placeTool(i) {
    const { points, axes, kinds } = this.track || {};
    if (!points || !points.length || !this.tool) return;
    const tip = new THREE.Vector3().fromArray(points, 3 * i);
    const axis = axes ? new THREE.Vector3().fromArray(axes, 3 * i) : new THREE.Vector3(0, 0, 1);
    if (axis.lengthSq() < 1e-12) axis.set(0, 0, 1);
    axis.normalize();
    this.tool.position.copy(tip);
    this.tool.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), axis);
    const f = (x) => x.toFixed(3);
    this.readout.textContent = `point ${i + 1} of ${points.length / 3} (${kinds[i]}): ` +
      `${f(tip.x)}, ${f(tip.y)}, ${f(tip.z)} mm; axis ${f(axis.x)}, ${f(axis.y)}, ${f(axis.z)}`;
    this.render();
  }

  /** Look at everything from the front, a little above, the whole part in view. */
  frame(box) {
    const centre = box.getCenter(new THREE.Vector3());
    const radius = Math.max(box.getSize(new THREE.Vector3()).length() / 2, 1);
    // the bounding sphere inside the narrower of the vertical and horizontal fields of view
    const halfHeight = THREE.MathUtils.degToRad(this.camera.fov / 2);
    const halfWidth = Math.atan(Math.tan(halfHeight) * this.camera.aspect);
    const distance = 0.95 * radius / Math.sin(Math.min(halfHeight, halfWidth));
    this.camera.near = distance / 100;
    this.camera.far = distance * 10;
    this.camera.position.copy(centre).add(new THREE.Vector3(0.6, -1, 0.7).normalize()
                                          .multiplyScalar(distance));
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(centre);
    this.controls.update();
    this.render();
  }
}

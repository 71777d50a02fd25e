// The 3D view: three.js scene, orbit camera, grid, the model's parts and
// skeleton, guiding curves with their control points, the live stroke, and
// the spread of the rule under the cursor. Renders on demand (after a change
// or a camera move), not in a loop.
//
// Materials are kept across models and redraws (MaterialCache): three.js
// deletes a shader program when the last material using it is disposed, and
// a new model or curve drawn with fresh materials then compiles its programs
// again, which costs tens of milliseconds per frame with software WebGL
// (docs/benchmarks.md, "Preview: edit to screen"). Geometry is rebuilt.
// Antialiasing (multisampling) is on only where WebGL runs on a GPU: on a
// software renderer it makes every frame several times slower.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { type Bezier, type V3, sampleBezier } from './bezier.js';
import type { Bounds, PickRange, SceneModel } from './protocol.js';
import { findPick } from './protocol.js';
import type { Ray } from './manip.js';
import type { ScopeLines } from './scopes.js';

const CURVE_COLOR = 0x3a8dde;
/** The tint of a curve's stretches that no bone follows (docs/curves.md 2.8). */
const GAP_COLOR = 0xff5a4a;
const CURVE_SELECTED = 0xff8c1a;
const SKELETON_COLOR = 0xd04020;
const HIGHLIGHT_COLOR = 0xffe14d;
const SPREAD_COLOR = 0xff40c0;
/** Shape mode: the picked shape's ancestors' scopes, its own, and the split planes. */
const SCOPE_COLOR = 0x7fb0ff;
const SCOPE_PICKED_COLOR = 0xffe14d;
const SCOPE_CUT_COLOR = 0xff8c1a;
/** Direct manipulation: the draggable planes and bone tips, and the one being dragged. */
const HANDLE_COLOR = 0x3fd6a0;
const HANDLE_ACTIVE_COLOR = 0xffffff;
/** A grip's diameter on screen, in CSS pixels (a press within 12 pixels of its centre grabs it). */
const GRIP_PX = 13;

let gripMap: THREE.Texture | null = null;

/** A round dot (the grips are points, square without it), made once. */
function gripTexture(): THREE.Texture {
  if (gripMap) return gripMap;
  const c = document.createElement('canvas');
  c.width = c.height = 64;
  const ctx = c.getContext('2d');
  if (ctx) {
    ctx.fillStyle = '#ffffff';
    ctx.beginPath();
    ctx.arc(32, 32, 30, 0, Math.PI * 2);
    ctx.fill();
  }
  gripMap = new THREE.CanvasTexture(c);
  return gripMap;
}

/**
 * Direct manipulation's handles as the scene draws them: grips (a sphere
 * each, hit-tested on screen) and line segments (flattened pairs of points:
 * a plane's rectangle, a bone's stick), those of the handle being dragged
 * apart.
 */
export interface HandleView {
  grips: { at: V3; active: boolean }[];
  lines: number[];
  activeLines: number[];
}

export interface PartHit {
  part: number;
  triangle: number;
  pick: PickRange | null;
  point: V3;
}

/** Renderer names of WebGL without a GPU (Chromium's SwiftShader, Mesa's llvmpipe and softpipe, Windows' WARP). */
export const SOFTWARE_RENDERER = /swiftshader|llvmpipe|softpipe|lavapipe|software|basic render/i;

/** The name of the WebGL renderer (the unmasked one where the browser tells it), from a throwaway context. */
export function webglRendererName(): string {
  const c = document.createElement('canvas');
  const gl = c.getContext('webgl2') ?? c.getContext('webgl');
  if (!gl) return '';
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const name = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER) ?? '');
  gl.getExtension('WEBGL_lose_context')?.loseContext();
  return name;
}

/** Materials by a key of their settings; a cached material outlives the objects drawn with it. */
export class MaterialCache {
  private readonly cache = new Map<string, THREE.Material>();

  get<T extends THREE.Material>(key: string, make: () => T): T {
    let m = this.cache.get(key);
    if (!m) {
      m = make();
      m.userData.cached = true;
      this.cache.set(key, m);
    }
    return m as T;
  }

  /** Dispose the materials not in `keep` (call it after a frame drew `keep`, so their programs stay). */
  prune(keep: Set<THREE.Material>): void {
    for (const [k, m] of this.cache) {
      if (keep.has(m)) continue;
      this.cache.delete(k);
      m.dispose();
    }
  }

  dispose(): void {
    this.prune(new Set());
  }
}

/** Dispose an object's geometries and its materials, except cached ones. */
function disposeObject(o: THREE.Object3D): void {
  o.traverse((c) => {
    const m = c as THREE.Mesh;
    if (m.geometry) m.geometry.dispose();
    const mat = m.material as THREE.Material | THREE.Material[] | undefined;
    for (const x of Array.isArray(mat) ? mat : mat ? [mat] : []) if (!x.userData.cached) x.dispose();
  });
}

function clearGroup(g: THREE.Group): void {
  for (const c of [...g.children]) {
    g.remove(c);
    disposeObject(c);
  }
}

/**
 * Meshes (one per part) and the skeleton of a model, in a fresh group, with
 * materials from `cache`; `used` is the set of materials the model needs.
 */
export function buildModelObjects(
  model: SceneModel,
  cache: MaterialCache,
): { geometry: THREE.Group; skeleton: THREE.LineSegments; used: Set<THREE.Material> } {
  const geometry = new THREE.Group();
  const used = new Set<THREE.Material>();
  const materials = model.materials.map((m) =>
    cache.get(`standard ${m.color.join(' ')} ${m.roughness} ${m.metallic} ${m.opacity}`, () => {
      const mat = new THREE.MeshStandardMaterial({
        color: new THREE.Color().setRGB(m.color[0], m.color[1], m.color[2], THREE.LinearSRGBColorSpace),
        roughness: m.roughness,
        metalness: m.metallic,
        side: THREE.DoubleSide,
      });
      if (m.opacity < 1) {
        mat.transparent = true;
        mat.opacity = m.opacity;
      }
      return mat;
    }),
  );
  model.parts.forEach((p, i) => {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(p.positions, 3));
    if (p.normals) g.setAttribute('normal', new THREE.BufferAttribute(p.normals, 3));
    g.setIndex(new THREE.BufferAttribute(p.indices, 1));
    if (!p.normals) g.computeVertexNormals();
    g.computeBoundingSphere();
    const mat = materials[p.material] ?? cache.get('standard default', () => new THREE.MeshStandardMaterial({ color: 0xcccccc, side: THREE.DoubleSide }));
    used.add(mat);
    const mesh = new THREE.Mesh(g, mat);
    mesh.userData.part = i;
    geometry.add(mesh);
  });
  const pos = new Float32Array(model.bones.length * 6);
  model.bones.forEach((b, i) => {
    pos.set(b.base, i * 6);
    pos.set(b.tip, i * 6 + 3);
  });
  const sg = new THREE.BufferGeometry();
  sg.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  // Depth-tested: the tubes hide the bones inside them; with the geometry
  // hidden the skeleton shows whole. Opaque, so the highlight (drawn later)
  // stays on top of it.
  const skeletonMaterial = cache.get('skeleton', () => new THREE.LineBasicMaterial({ color: SKELETON_COLOR }));
  used.add(skeletonMaterial);
  const skeleton = new THREE.LineSegments(sg, skeletonMaterial);
  skeleton.renderOrder = 2;
  return { geometry, skeleton, used };
}

function addLights(scene: THREE.Scene): void {
  scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 1.6));
  const sun = new THREE.DirectionalLight(0xffffff, 2.2);
  sun.position.set(3, 6, 4);
  scene.add(sun);
}

export class PreviewScene {
  readonly renderer: THREE.WebGLRenderer;
  readonly scene = new THREE.Scene();
  readonly camera: THREE.PerspectiveCamera;
  readonly controls: OrbitControls;
  private readonly grid: THREE.GridHelper;
  private readonly modelRoot = new THREE.Group();
  private readonly skeletonRoot = new THREE.Group();
  private readonly curvesRoot = new THREE.Group();
  /** The uncovered stretches of the guiding curves, tinted. */
  private readonly gapsRoot = new THREE.Group();
  private gaps: V3[][] = [];
  private readonly overlayRoot = new THREE.Group();
  /** The parts of the node chosen in the derivation tree (its subtree's triangles and bones). */
  private readonly chosenRoot = new THREE.Group();
  /** Shape mode: the scopes of the picked shape's path (wireframe). */
  private readonly scopesRoot = new THREE.Group();
  /** Direct manipulation's handles (drawn over everything). */
  private readonly handlesRoot = new THREE.Group();
  private handleGrips: V3[] = [];
  private readonly strokeLine: THREE.Line;
  private model: SceneModel | null = null;
  /** The model's materials (pruned to the current model's after each new model is drawn). */
  private readonly modelMaterials = new MaterialCache();
  /** The materials of the model shown. */
  private modelUsed = new Set<THREE.Material>();
  /** Curves, handles, highlight: a fixed set of materials. */
  private readonly materials = new MaterialCache();
  private curves: Bezier[] = [];
  /** What the curves group shows: curves, selection, handle size (redrawn only when it changes). */
  private curvesDrawn = '';
  private selected: number | null = null;
  private showSkeleton = true;
  private showGeometry = true;
  private frameRequested = false;
  private afterRender: Array<() => void> = [];
  private handleRadius = 0.06;
  private readonly raycaster = new THREE.Raycaster();

  /** Called when the camera moves (a drag: on every frame; `frame`: through the controls' `change`) or the canvas changes size. */
  onViewChange: () => void = () => {};

  /** The WebGL renderer's name, and whether frames are multisampled (not on a software renderer). */
  readonly rendererName: string;
  readonly antialias: boolean;

  constructor(private readonly canvas: HTMLCanvasElement) {
    this.rendererName = webglRendererName();
    this.antialias = !SOFTWARE_RENDERER.test(this.rendererName);
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: this.antialias, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(2, globalThis.devicePixelRatio || 1));
    this.renderer.setClearColor(0x1e1f22);
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.01, 1000);
    this.camera.position.set(6, 4, 8);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.target.set(0, 2, 0);
    this.controls.addEventListener('change', () => {
      this.requestRender();
      this.onViewChange();
    });
    this.grid = new THREE.GridHelper(20, 20, 0x666666, 0x3a3a3a);
    this.scene.add(this.grid);
    addLights(this.scene);
    this.scene.add(this.modelRoot, this.skeletonRoot, this.curvesRoot, this.gapsRoot, this.overlayRoot, this.chosenRoot, this.scopesRoot, this.handlesRoot);
    const sg = new THREE.BufferGeometry();
    sg.setAttribute('position', new THREE.BufferAttribute(new Float32Array(0), 3));
    this.strokeLine = new THREE.Line(sg, new THREE.LineBasicMaterial({ color: 0xffffff, depthTest: false }));
    this.strokeLine.renderOrder = 5;
    this.scene.add(this.strokeLine);
    this.resize();
  }

  resize(): void {
    const w = Math.max(1, this.canvas.clientWidth);
    const h = Math.max(1, this.canvas.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.requestRender();
    this.onViewChange();
  }

  /**
   * The camera's direction from the point it orbits (not normalised), the
   * camera itself (where it is, the point it orbits, its vertical field of
   * view in degrees: a picture through it frames what the canvas shows), and
   * the canvas' size in CSS pixels (0 while hidden).
   */
  view(): { direction: V3; camera: { position: V3; target: V3; fov: number }; width: number; height: number } {
    const p = this.camera.position;
    const t = this.controls.target;
    return {
      direction: [p.x - t.x, p.y - t.y, p.z - t.z],
      // The effective field of view: a camera zoom narrows it (the orbit controls dolly instead, but a zoom must not be lost).
      camera: { position: [p.x, p.y, p.z], target: [t.x, t.y, t.z], fov: this.camera.getEffectiveFOV() },
      width: this.canvas.clientWidth,
      height: this.canvas.clientHeight,
    };
  }

  /** Render at the next animation frame; `then` runs right after that render. */
  requestRender(then?: () => void): void {
    if (then) this.afterRender.push(then);
    if (this.frameRequested) return;
    this.frameRequested = true;
    requestAnimationFrame(() => {
      this.frameRequested = false;
      this.renderer.render(this.scene, this.camera);
      const cbs = this.afterRender;
      this.afterRender = [];
      for (const cb of cbs) cb();
    });
  }

  get hasModel(): boolean {
    return this.model !== null;
  }

  /** Number of meshes shown for the model (one per part). */
  get meshCount(): number {
    return this.modelRoot.children.length;
  }

  /** Replace the model; `frame` fits the camera to it. */
  setModel(model: SceneModel | null, frame: boolean, then?: () => void): void {
    clearGroup(this.modelRoot);
    clearGroup(this.skeletonRoot);
    // The chosen node's runs index the old model's triangles.
    clearGroup(this.chosenRoot);
    this.model = model;
    this.modelUsed = new Set();
    if (model) {
      const built = buildModelObjects(model, this.modelMaterials);
      this.modelUsed = built.used;
      for (const c of [...built.geometry.children]) this.modelRoot.add(c);
      this.skeletonRoot.add(built.skeleton);
      if (frame && model.bounds) this.frame(model.bounds);
    }
    this.modelRoot.visible = this.showGeometry;
    this.skeletonRoot.visible = this.showSkeleton;
    // Materials the new model no longer uses go once it is drawn (its own
    // materials have their programs by then, so shared programs survive).
    this.requestRender(() => this.modelMaterials.prune(this.modelUsed));
    if (then) this.requestRender(then);
  }

  /** Ids of the shader programs three.js holds (for tests: a new model compiles none). */
  programIds(): number[] {
    return (this.renderer.info.programs ?? []).map((p) => p.id).sort((a, b) => a - b);
  }

  setShowSkeleton(on: boolean): void {
    this.showSkeleton = on;
    this.skeletonRoot.visible = on;
    this.requestRender();
  }

  setShowGeometry(on: boolean): void {
    this.showGeometry = on;
    this.modelRoot.visible = on;
    this.requestRender();
  }

  /** Point the camera at the bounds (union with the curves) from a three-quarter view. */
  frame(bounds: Bounds): void {
    const b = new THREE.Box3(new THREE.Vector3(...bounds.min), new THREE.Vector3(...bounds.max));
    for (const c of this.curves) for (const p of c) b.expandByPoint(new THREE.Vector3(...p));
    const centre = b.getCenter(new THREE.Vector3());
    const size = b.getSize(new THREE.Vector3());
    const radius = Math.max(0.5, size.length() / 2);
    const dist = radius / Math.sin(THREE.MathUtils.degToRad(this.camera.fov / 2));
    const dir = new THREE.Vector3(0.45, 0.35, 1).normalize();
    this.controls.target.copy(centre);
    this.camera.position.copy(centre).addScaledVector(dir, dist * 1.05);
    this.camera.near = dist / 100;
    this.camera.far = dist * 100;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.handleRadius = radius * 0.025;
    const gridSize = Math.max(10, Math.ceil(radius * 4));
    this.grid.scale.setScalar(gridSize / 20);
    this.drawCurves();
    this.drawGaps();
    this.requestRender();
  }

  /** The point the camera orbits: the scene's centre for drawing. */
  centre(): V3 {
    const t = this.controls.target;
    return [t.x, t.y, t.z];
  }

  /** Show these curves; nothing is redrawn if they are what is shown (a drag's release where its last move was). */
  setCurves(curves: Bezier[], selected: number | null): void {
    this.curves = curves;
    this.selected = selected;
    this.drawCurves(false);
  }

  /** Times the curves were drawn (for tests: an unchanged set is not redrawn). */
  curveDraws = 0;

  private drawCurves(always = true): void {
    const drawn = JSON.stringify([this.curves, this.selected, this.handleRadius]);
    if (!always && drawn === this.curvesDrawn) return;
    this.curvesDrawn = drawn;
    this.curveDraws++;
    clearGroup(this.curvesRoot);
    const basic = (color: number) => this.materials.get(`basic ${color}`, () => new THREE.MeshBasicMaterial({ color, depthTest: false }));
    this.curves.forEach((c, i) => {
      const sel = i === this.selected;
      const pts = sampleBezier(c, 64).map((p) => new THREE.Vector3(...p));
      const g = new THREE.BufferGeometry().setFromPoints(pts);
      const color = sel ? CURVE_SELECTED : CURVE_COLOR;
      const line = new THREE.Line(g, this.materials.get(`line ${color}`, () => new THREE.LineBasicMaterial({ color, depthTest: false })));
      line.renderOrder = 3;
      this.curvesRoot.add(line);
      // An arrow head at the end: a curve's direction matters (docs/curves.md 2.3).
      const end = pts[pts.length - 1];
      const dir = end.clone().sub(pts[pts.length - 3]).normalize();
      if (dir.lengthSq() > 0) {
        const cone = new THREE.Mesh(new THREE.ConeGeometry(this.handleRadius * 1.2, this.handleRadius * 4, 12), basic(color));
        cone.position.copy(end);
        cone.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), dir);
        cone.renderOrder = 3;
        this.curvesRoot.add(cone);
      }
      if (sel) {
        const dashed = this.materials.get('dashed', () => new THREE.LineDashedMaterial({ color: 0xaaaaaa, depthTest: false }));
        // Uniforms: changing them needs no new program.
        dashed.dashSize = this.handleRadius * 2;
        dashed.gapSize = this.handleRadius;
        const poly = new THREE.Line(new THREE.BufferGeometry().setFromPoints(c.map((p) => new THREE.Vector3(...p))), dashed);
        poly.computeLineDistances();
        poly.renderOrder = 3;
        this.curvesRoot.add(poly);
        c.forEach((p, k) => {
          const h = new THREE.Mesh(new THREE.SphereGeometry(this.handleRadius * (k === 0 || k === 3 ? 1.2 : 1), 12, 8), basic(k === 0 || k === 3 ? 0xffffff : CURVE_SELECTED));
          h.position.set(...p);
          h.renderOrder = 4;
          this.curvesRoot.add(h);
        });
      }
    });
    this.requestRender();
  }

  /** Tubes drawn along the curves' uncovered stretches (for tests). */
  gapTubes = 0;

  /** Tint the stretches of the guiding curves that the model does not follow (each a polyline along its curve); [] clears them. */
  setGaps(gaps: V3[][]): void {
    this.gaps = gaps;
    this.drawGaps();
  }

  private drawGaps(): void {
    clearGroup(this.gapsRoot);
    this.gapTubes = 0;
    const material = this.materials.get('gap', () => new THREE.MeshBasicMaterial({ color: GAP_COLOR, depthTest: false, transparent: true, opacity: 0.85 }));
    for (const line of this.gaps) {
      const pts = line.map((p) => new THREE.Vector3(...p));
      if (pts.length < 2) continue;
      const path = new THREE.CatmullRomCurve3(pts, false, 'centripetal');
      const tube = new THREE.Mesh(new THREE.TubeGeometry(path, Math.max(2, pts.length), this.handleRadius * 0.5, 6, false), material);
      tube.renderOrder = 3;
      this.gapsRoot.add(tube);
      this.gapTubes++;
    }
    this.requestRender();
  }

  /** Show the stroke being drawn (world points). */
  setStroke(points: V3[]): void {
    const g = new THREE.BufferGeometry().setFromPoints(points.map((p) => new THREE.Vector3(...p)));
    this.strokeLine.geometry.dispose();
    this.strokeLine.geometry = g;
    this.requestRender();
  }

  /** Segments drawn for the scopes (0: none shown). */
  scopeSegments = 0;

  /** Draw the scopes of a picked shape's path as wireframe boxes and split planes (null: none). */
  setScopes(lines: ScopeLines | null): void {
    clearGroup(this.scopesRoot);
    this.scopeSegments = 0;
    if (lines) {
      const add = (pos: number[], key: string, color: number, opacity: number, order: number): void => {
        if (pos.length === 0) return;
        const g = new THREE.BufferGeometry();
        g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
        const m = this.materials.get(key, () => new THREE.LineBasicMaterial({ color, depthTest: false, transparent: opacity < 1, opacity }));
        const l = new THREE.LineSegments(g, m);
        l.renderOrder = order;
        this.scopesRoot.add(l);
        this.scopeSegments += pos.length / 6;
      };
      add(lines.boxes, 'scope', SCOPE_COLOR, 0.6, 6);
      add(lines.cuts, 'scope cut', SCOPE_CUT_COLOR, 0.9, 7);
      add(lines.picked, 'scope picked', SCOPE_PICKED_COLOR, 1, 8);
    }
    this.requestRender();
  }

  /** Draw direct manipulation's handles (null: none). */
  setHandles(v: HandleView | null): void {
    clearGroup(this.handlesRoot);
    this.handleGrips = v ? v.grips.map((g) => g.at) : [];
    if (v) {
      const lines = (pos: number[], color: number, order: number): void => {
        if (pos.length === 0) return;
        const g = new THREE.BufferGeometry();
        g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
        const l = new THREE.LineSegments(g, this.materials.get(`handle line ${color}`, () => new THREE.LineBasicMaterial({ color, depthTest: false })));
        l.renderOrder = order;
        this.handlesRoot.add(l);
      };
      lines(v.lines, HANDLE_COLOR, 9);
      lines(v.activeLines, HANDLE_ACTIVE_COLOR, 10);
      // Grips as dots of a fixed size on screen (a model's scale says nothing of how big a hand is).
      const dots = (pts: V3[], color: number, px: number, order: number): void => {
        if (pts.length === 0) return;
        // Drawing-buffer pixels: a CSS pixel is `pixelRatio` of them.
        const size = px * this.renderer.getPixelRatio();
        const g = new THREE.BufferGeometry();
        g.setAttribute('position', new THREE.Float32BufferAttribute(pts.flat(), 3));
        const m = this.materials.get(
          `handle grip ${color} ${size}`,
          () => new THREE.PointsMaterial({ color, size, sizeAttenuation: false, map: gripTexture(), alphaTest: 0.5, depthTest: false, transparent: true }),
        );
        const p = new THREE.Points(g, m);
        p.renderOrder = order;
        this.handlesRoot.add(p);
      };
      dots(v.grips.filter((g) => !g.active).map((g) => g.at), HANDLE_COLOR, GRIP_PX, 11);
      dots(v.grips.filter((g) => g.active).map((g) => g.at), HANDLE_ACTIVE_COLOR, GRIP_PX + 2, 12);
    }
    this.requestRender();
  }

  /** Grips drawn (for tests). */
  get handleCount(): number {
    return this.handleGrips.length;
  }

  /** The grip nearest the pointer on screen, within `px` pixels (its index in the last `setHandles`). */
  gripAt(clientX: number, clientY: number, px = 12): number | null {
    let best: number | null = null;
    let bestD = px;
    this.handleGrips.forEach((p, i) => {
      const [x, y] = this.toScreen(p);
      const d = Math.hypot(x - clientX, y - clientY);
      if (d < bestD) {
        bestD = d;
        best = i;
      }
    });
    return best;
  }

  /** The ray from the camera through the pointer (world frame). */
  pointerRay(clientX: number, clientY: number): Ray {
    this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
    const { origin, direction } = this.raycaster.ray;
    return { origin: [origin.x, origin.y, origin.z], dir: [direction.x, direction.y, direction.z] };
  }

  /** Where the camera looks (a unit vector): the normal of the view plane. */
  viewDirection(): V3 {
    const d = this.camera.getWorldDirection(new THREE.Vector3());
    return [d.x, d.y, d.z];
  }

  /**
   * Highlight what a chosen node of the derivation tree drew: `triangles` as (part, first triangle, count) triples
   * (`grm/tree`'s `drawn`), tinted over the model, and `bones` (indices) as lines over everything. Empty: none.
   * Returns the triangles and bones highlighted.
   */
  setChosen(triangles: number[], bones: number[]): { triangles: number; bones: number } {
    clearGroup(this.chosenRoot);
    const model = this.model;
    let tris = 0;
    let lit = 0;
    if (model) {
      const byPart = new Map<number, number[]>();
      for (let i = 0; i + 2 < triangles.length; i += 3) {
        const [part, first, count] = [triangles[i]!, triangles[i + 1]!, triangles[i + 2]!];
        const p = model.parts[part];
        if (!p) continue;
        const end = Math.min(first + count, p.indices.length / 3);
        if (end <= first) continue;
        let idx = byPart.get(part);
        if (!idx) byPart.set(part, (idx = []));
        for (let k = 3 * first; k < 3 * end; k++) idx.push(p.indices[k]!);
        tris += end - first;
      }
      const tint = this.materials.get(
        'chosen',
        () =>
          new THREE.MeshBasicMaterial({ color: HIGHLIGHT_COLOR, transparent: true, opacity: 0.55, side: THREE.DoubleSide, depthWrite: false, polygonOffset: true, polygonOffsetFactor: -2, polygonOffsetUnits: -2 }),
      );
      for (const [part, idx] of byPart) {
        const g = new THREE.BufferGeometry();
        g.setAttribute('position', new THREE.BufferAttribute(model.parts[part]!.positions, 3));
        g.setIndex(idx);
        const m = new THREE.Mesh(g, tint);
        m.renderOrder = 4;
        this.chosenRoot.add(m);
      }
      const pos: number[] = [];
      for (const i of bones) {
        const b = model.bones[i];
        if (!b) continue;
        pos.push(...b.base, ...b.tip);
        lit++;
      }
      if (pos.length > 0) {
        const g = new THREE.BufferGeometry();
        g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
        const l = new THREE.LineSegments(g, this.materials.get('highlight', () => new THREE.LineBasicMaterial({ color: HIGHLIGHT_COLOR, depthTest: false })));
        l.renderOrder = 6;
        this.chosenRoot.add(l);
      }
    }
    this.requestRender();
    return { triangles: tris, bones: lit };
  }

  /** Highlight bones (indices into the model's bones) and draw spread segments (bones from other seeds) faintly. */
  setHighlight(bones: number[], spread: [V3, V3][]): void {
    clearGroup(this.overlayRoot);
    if (this.model && bones.length > 0) {
      const pos: number[] = [];
      for (const i of bones) {
        const b = this.model.bones[i];
        if (b) pos.push(...b.base, ...b.tip);
      }
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
      const l = new THREE.LineSegments(g, this.materials.get('highlight', () => new THREE.LineBasicMaterial({ color: HIGHLIGHT_COLOR, depthTest: false })));
      l.renderOrder = 6;
      this.overlayRoot.add(l);
    }
    if (spread.length > 0) {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(spread.flat(2), 3));
      const lines = new THREE.LineSegments(
        g,
        this.materials.get('spread', () => new THREE.LineBasicMaterial({ color: SPREAD_COLOR, transparent: true, opacity: 0.3, depthTest: false })),
      );
      lines.renderOrder = 5;
      this.overlayRoot.add(lines);
      // The tips: where the rule puts things, as dots.
      const tips = new THREE.BufferGeometry();
      tips.setAttribute('position', new THREE.Float32BufferAttribute(spread.flatMap((s) => s[1]), 3));
      const pts = new THREE.Points(
        tips,
        this.materials.get('spread tips', () => new THREE.PointsMaterial({ color: SPREAD_COLOR, size: 2.5, sizeAttenuation: false, transparent: true, opacity: 0.5, depthTest: false })),
      );
      pts.renderOrder = 6;
      this.overlayRoot.add(pts);
    }
    this.requestRender();
  }

  // ----------------------------------------------------------- picking

  private ndc(clientX: number, clientY: number): THREE.Vector2 {
    const r = this.canvas.getBoundingClientRect();
    return new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
  }

  /** Screen position (client pixels) of a world point. */
  toScreen(p: V3): [number, number] {
    const r = this.canvas.getBoundingClientRect();
    const v = new THREE.Vector3(...p).project(this.camera);
    return [r.left + ((v.x + 1) / 2) * r.width, r.top + ((1 - v.y) / 2) * r.height];
  }

  /** The model triangle under the pointer, if geometry is shown. */
  pickPart(clientX: number, clientY: number): PartHit | null {
    if (!this.model || !this.showGeometry) return null;
    this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
    const hits = this.raycaster.intersectObjects(this.modelRoot.children, false);
    for (const h of hits) {
      const part = h.object.userData.part as number | undefined;
      if (part === undefined || h.faceIndex == null) continue;
      const p = this.model.parts[part];
      return { part, triangle: h.faceIndex, pick: p ? findPick(p, h.faceIndex) : null, point: [h.point.x, h.point.y, h.point.z] };
    }
    return null;
  }

  /** The bone nearest the pointer on screen (within `px`), for skeleton-only views. */
  pickBone(clientX: number, clientY: number, px = 6): number | null {
    if (!this.model || !this.showSkeleton) return null;
    let best: number | null = null;
    let bestD = px;
    this.model.bones.forEach((b, i) => {
      const d = segmentDistance([clientX, clientY], this.toScreen(b.base), this.toScreen(b.tip));
      if (d < bestD) {
        bestD = d;
        best = i;
      }
    });
    return best;
  }

  /** The curve whose drawn line passes within `px` pixels of the pointer. */
  curveAt(clientX: number, clientY: number, px = 8): number | null {
    let best: number | null = null;
    let bestD = px;
    this.curves.forEach((c, i) => {
      const pts = sampleBezier(c, 48).map((p) => this.toScreen(p));
      for (let k = 1; k < pts.length; k++) {
        const d = segmentDistance([clientX, clientY], pts[k - 1], pts[k]);
        if (d < bestD) {
          bestD = d;
          best = i;
        }
      }
    });
    return best;
  }

  /** The control point of the selected curve under the pointer. */
  handleAt(clientX: number, clientY: number, px = 10): number | null {
    if (this.selected === null) return null;
    const c = this.curves[this.selected];
    if (!c) return null;
    let best: number | null = null;
    let bestD = px;
    c.forEach((p, k) => {
      const [x, y] = this.toScreen(p);
      const d = Math.hypot(x - clientX, y - clientY);
      if (d < bestD) {
        bestD = d;
        best = k;
      }
    });
    return best;
  }

  /**
   * Where the pointer's ray meets the plane that faces the camera and passes
   * through `through` (the scene's centre when drawing, the dragged point
   * when moving a control point).
   */
  planePoint(clientX: number, clientY: number, through: V3): V3 | null {
    this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
    const normal = this.camera.getWorldDirection(new THREE.Vector3());
    const plane = new THREE.Plane().setFromNormalAndCoplanarPoint(normal, new THREE.Vector3(...through));
    const hit = this.raycaster.ray.intersectPlane(plane, new THREE.Vector3());
    return hit ? [hit.x, hit.y, hit.z] : null;
  }

  dispose(): void {
    this.controls.dispose();
    disposeObject(this.scene);
    this.modelMaterials.dispose();
    this.materials.dispose();
    this.renderer.dispose();
  }
}

/** Distance from point p to segment ab, in the same units. */
export function segmentDistance(p: [number, number], a: [number, number], b: [number, number]): number {
  const dx = b[0] - a[0];
  const dy = b[1] - a[1];
  const len2 = dx * dx + dy * dy;
  const t = len2 > 0 ? Math.max(0, Math.min(1, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2)) : 0;
  return Math.hypot(p[0] - (a[0] + t * dx), p[1] - (a[1] + t * dy));
}

/** Renders small pictures of models for the variation gallery, with one shared renderer. */
export class ThumbnailRenderer {
  private readonly renderer: THREE.WebGLRenderer;
  private readonly scene = new THREE.Scene();
  private readonly camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
  private readonly materials = new MaterialCache();

  constructor(size = 160) {
    const canvas = document.createElement('canvas');
    canvas.width = size;
    canvas.height = size;
    // One picture per model, not a frame per edit: multisampled even on a software renderer.
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setSize(size, size, false);
    this.renderer.setClearColor(0x26272b);
    addLights(this.scene);
  }

  /** A PNG data URL of the model, framed from the given view direction. */
  render(model: SceneModel, viewDir: V3): string {
    const { geometry, skeleton, used } = buildModelObjects(model, this.materials);
    skeleton.geometry.dispose();
    this.scene.add(geometry);
    if (model.bounds) {
      const b = new THREE.Box3(new THREE.Vector3(...model.bounds.min), new THREE.Vector3(...model.bounds.max));
      const centre = b.getCenter(new THREE.Vector3());
      const radius = Math.max(0.5, b.getSize(new THREE.Vector3()).length() / 2);
      const dist = radius / Math.sin(THREE.MathUtils.degToRad(this.camera.fov / 2));
      this.camera.position.copy(centre).addScaledVector(new THREE.Vector3(...viewDir).normalize(), dist);
      this.camera.near = dist / 100;
      this.camera.far = dist * 100;
      this.camera.lookAt(centre);
      this.camera.updateProjectionMatrix();
    }
    this.renderer.render(this.scene, this.camera);
    const url = this.renderer.domElement.toDataURL('image/png');
    this.scene.remove(geometry);
    disposeObject(geometry);
    this.materials.prune(used);
    return url;
  }

  dispose(): void {
    this.materials.dispose();
    this.renderer.dispose();
  }
}

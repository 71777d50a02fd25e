// The layout view's 3D mode (issue 29, item 6; docs/layout.md, "In the
// editor"): the city with a building on every parcel, drawn by the page's
// three.js renderer from `grm/layoutCity`'s mesh buffers (the parts and
// materials `grm/preview` answers: base64 text, or protocol 3's blob, which
// the transports put in place), in an orbiting view. After a drag the view
// asks again; the server grows only the parcels the move changed (its
// building cache) and the camera stays where the artist left it.
//
// The pure parts (the answer's decoding, the caption, the camera's framing)
// are exported for the unit tests (editors/test/layout-3d.test.ts).

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { type Bounds, type SceneModel, decodeModel } from './protocol.js';
import { MaterialCache, SOFTWARE_RENDERER, buildModelObjects, webglRendererName } from './scene.js';

export interface CityProblem {
  code: string;
  message: string;
}

/** A `grm/layoutCity` answer: the city's model and what grew. */
export interface LayoutCity {
  model: SceneModel;
  buildings: number;
  reused: number;
  edited: number;
  parcels: number;
  growMs: number;
  problems: CityProblem[];
}

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

function count(v: unknown, what: string): number {
  if (typeof v !== 'number' || !Number.isFinite(v) || v < 0) throw new Error(`layoutCity.${what}: not a count`);
  return v;
}

/** Read a `grm/layoutCity` answer (throws on a malformed one). */
export function decodeLayoutCity(raw: unknown): LayoutCity {
  if (!isObject(raw)) throw new Error('layoutCity: not an object');
  if (!Array.isArray(raw.parts)) throw new Error('layoutCity.parts: not an array');
  const model = decodeModel({ materials: raw.materials, parts: raw.parts, stats: { boundsMin: raw.boundsMin, boundsMax: raw.boundsMax } });
  const problems = (Array.isArray(raw.problems) ? raw.problems : []).map((p: unknown, i: number) => {
    if (!isObject(p) || typeof p.code !== 'string' || typeof p.message !== 'string') throw new Error(`layoutCity.problems[${i}]: not a problem`);
    return { code: p.code, message: p.message };
  });
  return {
    model,
    buildings: count(raw.buildings, 'buildings'),
    reused: count(raw.reused, 'reused'),
    edited: typeof raw.edited === 'number' ? raw.edited : 0,
    parcels: count(raw.parcels, 'parcels'),
    growMs: count(raw.growMs, 'growMs'),
    problems,
  };
}

/** What the 3D mode says under its view. */
export function cityCaption(c: LayoutCity): string {
  const grown = c.buildings - c.reused;
  const edited = c.edited > 0 ? `; ${c.edited} with building edits` : '';
  return `${c.buildings} buildings on ${c.parcels} parcels; ${grown} grown in ${c.growMs.toFixed(0)} ms, ${c.reused} kept from the last update${edited}`;
}

/** The camera that shows `b` whole, from above at an angle (south-east, 35 degrees up), with `fov` degrees vertically. */
export function frameCity(b: Bounds, fov: number): { position: [number, number, number]; target: [number, number, number]; near: number; far: number } {
  const target: [number, number, number] = [(b.min[0] + b.max[0]) / 2, (b.min[1] + b.max[1]) / 2, (b.min[2] + b.max[2]) / 2];
  const size = Math.hypot(b.max[0] - b.min[0], b.max[1] - b.min[1], b.max[2] - b.min[2]);
  const radius = Math.max(1, size / 2);
  const dist = radius / Math.sin(((fov / 2) * Math.PI) / 180);
  const up = (35 * Math.PI) / 180;
  const round = (45 * Math.PI) / 180;
  const position: [number, number, number] = [
    target[0] + dist * Math.cos(up) * Math.sin(round),
    target[1] + dist * Math.sin(up),
    target[2] + dist * Math.cos(up) * Math.cos(round),
  ];
  return { position, target, near: dist / 200, far: dist * 20 };
}

/** The orbiting view of the city: its own canvas, renderer and camera; renders on demand. */
export class City3D {
  readonly canvas: HTMLCanvasElement;
  private renderer: THREE.WebGLRenderer | null = null;
  private readonly scene = new THREE.Scene();
  private readonly camera = new THREE.PerspectiveCamera(45, 1, 1, 10000);
  private controls: OrbitControls | null = null;
  private readonly root = new THREE.Group();
  private readonly materials = new MaterialCache();
  private framed = false;
  private frameRequested = false;
  /** Frames rendered (the browser test waits on it). */
  private frames = 0;

  constructor() {
    this.canvas = document.createElement('canvas');
    this.canvas.id = 'layout-city';
    this.canvas.style.cssText = 'flex:1;min-width:0;height:100%;display:block;touch-action:none';
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 2.2);
    sun.position.set(300, 600, 400);
    this.scene.add(sun, this.root);
  }

  /** The renderer, made on first use (a WebGL context only once 3D is asked for). */
  private ensure(): THREE.WebGLRenderer {
    if (this.renderer) return this.renderer;
    const antialias = !SOFTWARE_RENDERER.test(webglRendererName());
    this.renderer = new THREE.WebGLRenderer({ canvas: this.canvas, antialias, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(2, globalThis.devicePixelRatio || 1));
    this.renderer.setClearColor(0x1e1f22);
    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.addEventListener('change', () => this.requestRender());
    new ResizeObserver(() => this.resize()).observe(this.canvas);
    return this.renderer;
  }

  resize(): void {
    if (!this.renderer) return;
    const w = Math.max(1, this.canvas.clientWidth);
    const h = Math.max(1, this.canvas.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  /** Show a new city; the camera is framed on the first one only (after a drag it stays). */
  setModel(model: SceneModel): void {
    this.ensure();
    for (const c of [...this.root.children]) {
      this.root.remove(c);
      c.traverse((o) => (o as THREE.Mesh).geometry?.dispose());
    }
    const built = buildModelObjects(model, this.materials);
    built.skeleton.geometry.dispose();
    this.root.add(built.geometry);
    this.materials.prune(built.used);
    if (!this.framed && model.bounds) {
      const f = frameCity(model.bounds, this.camera.fov);
      this.camera.position.set(...f.position);
      this.camera.near = f.near;
      this.camera.far = f.far;
      this.controls?.target.set(...f.target);
      this.controls?.update();
      this.framed = true;
    }
    this.canvas.dataset.meshes = String(built.geometry.children.length);
    this.canvas.dataset.modelTriangles = String(model.triangles);
    this.resize();
  }

  /** Frame the next city anew (another layout shown). */
  reframe(): void {
    this.framed = false;
  }

  requestRender(): void {
    if (this.frameRequested || !this.renderer) return;
    this.frameRequested = true;
    requestAnimationFrame(() => {
      this.frameRequested = false;
      const r = this.renderer;
      if (!r) return;
      r.render(this.scene, this.camera);
      this.frames += 1;
      // What the last frame drew (the browser test reads it).
      this.canvas.dataset.frames = String(this.frames);
      this.canvas.dataset.drawnTriangles = String(r.info.render.triangles);
    });
  }
}

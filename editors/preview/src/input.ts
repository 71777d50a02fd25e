// Pointer and keyboard input in the preview's view: the tool (orbit or
// draw), a press, move and release (a curve drawn, a control point or a
// handle dragged, a click that picks) and the keyboard's shortcuts.

import type { V3 } from './bezier.js';
import { $ } from './dom.js';
import type { Gesture } from './gesture.js';
import type { App } from './main.js';

export class PointerInput {
  private tool: 'orbit' | 'draw' = 'orbit';
  /** What the pointer is doing in the view. */
  gesture: Gesture = { kind: 'none' };

  constructor(private readonly app: App) {}

  /** Wire its part of the page (listeners on its buttons and fields). */
  wire(): void {
    $('tool-orbit').addEventListener('click', () => this.setTool('orbit'));
    $('tool-draw').addEventListener('click', () => this.setTool('draw'));
    const vp = $('viewport');
    // Capture phase: decide before OrbitControls (registered on the canvas) sees the press.
    vp.addEventListener('pointerdown', (e) => this.pointerDown(e), { capture: true });
    window.addEventListener('pointermove', (e) => this.pointerMove(e));
    window.addEventListener('pointerup', (e) => this.pointerUp(e));
    window.addEventListener('keydown', (e) => this.key(e));
  }

  private setTool(t: 'orbit' | 'draw'): void {
    this.tool = t;
    $('tool-orbit').classList.toggle('active', t === 'orbit');
    $('tool-draw').classList.toggle('active', t === 'draw');
    $('viewport').classList.toggle('drawing', t === 'draw');
  }

  private key(e: KeyboardEvent): void {
    const target = e.target as HTMLElement | null;
    if (target && (target.tagName === 'INPUT' || target.tagName === 'SELECT' || target.tagName === 'TEXTAREA')) return;
    if ((e.ctrlKey || e.metaKey) && (e.key === 'z' || e.key === 'Z' || e.key === 'y')) {
      e.preventDefault();
      this.app.curves.undoRedo(e.key === 'y' || e.shiftKey);
      return;
    }
    if (e.key === 'd' || e.key === 'D') this.setTool(this.tool === 'draw' ? 'orbit' : 'draw');
    else if (e.key === 'o' || e.key === 'O') this.setTool('orbit');
    else if (e.key === 'n' || e.key === 'N') this.app.nextVariation();
    else if (e.key === 'f' || e.key === 'F') {
      if (this.app.last?.model.bounds) this.app.scene.frame(this.app.last.model.bounds);
    } else if (e.key === 'Delete' || e.key === 'Backspace') this.app.curves.deleteSelected();
    else if (e.key === 'Escape') {
      // The handles go with the selection.
      this.app.manipulation.drop();
      this.app.state.selected = null;
      this.app.curves.refreshCurves();
      this.app.refreshPanel();
    }
  }

  private pointerDown(e: PointerEvent): void {
    if (e.button !== 0) return;
    if (this.app.manipulation.grabHandle(e)) return;
    const handle = this.app.curves.showCurves ? this.app.scene.handleAt(e.clientX, e.clientY) : null;
    const sel = this.app.state.selected;
    if (handle !== null && sel !== null && this.app.state.curves) {
      this.gesture = { kind: 'drag', curve: sel, handle, through: [...this.app.state.curves.curves[sel].points[handle]] as V3, moved: false };
      this.app.scene.controls.enabled = false;
      e.stopPropagation();
      return;
    }
    if (this.tool === 'draw' || e.shiftKey) {
      if (this.app.state.mode !== 'sample') {
        this.app.setStatus('curves guide sample systems (mode = sample); this system is derived', true);
        return;
      }
      const centre = this.app.scene.centre();
      const p = this.app.scene.planePoint(e.clientX, e.clientY, centre);
      this.gesture = { kind: 'draw', points: p ? [p] : [], centre, startX: e.clientX, startY: e.clientY };
      this.app.scene.controls.enabled = false;
      e.stopPropagation();
      return;
    }
    this.gesture = { kind: 'click', x: e.clientX, y: e.clientY, t: performance.now() };
  }

  private pointerMove(e: PointerEvent): void {
    const g = this.gesture;
    if (g.kind === 'plane' || g.kind === 'tip') {
      this.app.manipulation.moveHandle(e);
    } else if (g.kind === 'draw') {
      const p = this.app.scene.planePoint(e.clientX, e.clientY, g.centre);
      if (p) {
        g.points.push(p);
        this.app.scene.setStroke(g.points);
      }
    } else if (g.kind === 'drag') {
      const p = this.app.scene.planePoint(e.clientX, e.clientY, g.through);
      if (p) {
        g.moved = true;
        this.app.state.moveControlPoint(g.curve, g.handle, p);
        this.app.curves.curvesChanged(false, 'move');
      }
    }
  }

  private pointerUp(e: PointerEvent): void {
    const g = this.gesture;
    this.gesture = { kind: 'none' };
    this.app.scene.controls.enabled = true;
    if (g.kind === 'plane' || g.kind === 'tip') {
      this.app.manipulation.releaseHandle(g);
    } else if (g.kind === 'draw') {
      this.app.scene.setStroke([]);
      const longEnough = Math.hypot(e.clientX - g.startX, e.clientY - g.startY) > 8 || g.points.length > 4;
      if (longEnough && this.app.state.addStroke(g.points) !== null) this.app.curves.curvesChanged(true);
    } else if (g.kind === 'drag') {
      if (g.moved) this.app.curves.curvesChanged(true, 'release');
    } else if (g.kind === 'click') {
      if (Math.hypot(e.clientX - g.x, e.clientY - g.y) < 5 && performance.now() - g.t < 600) this.click(e.clientX, e.clientY);
    }
  }

  private click(x: number, y: number): void {
    const curve = this.app.curves.showCurves ? this.app.scene.curveAt(x, y) : null;
    if (curve !== null) {
      this.app.state.selected = curve;
      this.app.curves.refreshCurves();
      this.app.refreshPanel();
      return;
    }
    if (this.app.state.selected !== null) {
      this.app.state.selected = null;
      this.app.curves.refreshCurves();
      this.app.refreshPanel();
    }
    void this.app.picking.pick(x, y);
  }
}

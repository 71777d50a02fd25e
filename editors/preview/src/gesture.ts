// What the pointer is doing in the preview's view (a curve drawn, a control
// point or a handle dragged, a click), shared by the page's pointer input,
// its curves and its direct manipulation.

import type { V3 } from './bezier.js';
import type { Ray } from './manip.js';

/** A bone's grips, in the order they are drawn (their index in the scene's grips). */
export const BONE_GRIPS = ['tip', 'length', 'angle'] as const;
export type BoneGrip = (typeof BONE_GRIPS)[number];

/** What the pointer is doing in the view: drawing a curve, dragging a control point or a handle, or a click. */
export type Gesture =
  | { kind: 'none' }
  | { kind: 'draw'; points: V3[]; centre: V3; startX: number; startY: number }
  | { kind: 'drag'; curve: number; handle: number; through: V3; moved: boolean }
  /** A split plane's handle (index into the handles) along its axis: grabbed at `at0` with the pointer's ray `ray0`. */
  | { kind: 'plane'; handle: number; at0: number; ray0: Ray; facing: V3; at: number; moved: boolean }
  /**
   * A bone's tip, in the plane through it with normal `normal`: moved by what the pointer moved in that plane since
   * the grab (where the grabbing ray met it, `grab`), so a grip pressed off its centre does not jump. `grip`: the tip
   * itself, or the grips beside it: `length` (along the bone; `length` is the new length) or `angle` (the bone
   * turned about its base in that plane, its length kept; `degrees` the turn).
   */
  | { kind: 'tip'; grip: BoneGrip; tip0: V3; normal: V3; grab: V3 | null; at: V3; length: number | null; degrees: number; moved: boolean }
  | { kind: 'click'; x: number; y: number; t: number };

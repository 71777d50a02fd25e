// The page's "Save picture", without any DOM: what it asks the host for (the
// current preview's parameters, through the preview's camera, in the
// canvas' shape) and what the picture file is called. Shared with the
// extension (its PNG export sizes pictures the same way). Unit-tested.

import { type CameraParams, usableCamera } from './messages.js';
import type { PictureParams, PreviewParams } from './protocol.js';

/** The longer side of a saved picture, in pixels (the extension's PNG export uses the same). */
export const PICTURE_LONGEST = 1024;

/**
 * A picture of the preview canvas' shape: `width` by `height` (any unit)
 * scaled so the longer side is `longest` pixels, the shorter at least 1.
 * Undefined for a canvas without a size.
 */
export function pictureSize(width: number, height: number, longest = PICTURE_LONGEST): { width: number; height: number } | undefined {
  if (!(width > 0 && height > 0 && Number.isFinite(width) && Number.isFinite(height))) return undefined;
  const scale = longest / Math.max(width, height);
  return { width: Math.max(1, Math.round(width * scale)), height: Math.max(1, Math.round(height * scale)) };
}

/**
 * The `picture` request for what the page shows: the parameters of its
 * preview request (seed, meta-parameters, mode, system, curves, and the
 * generation the scrubber shows of a sample system's search) with the
 * preview's camera (position, the point it orbits, vertical field of view)
 * and the picture's size from the canvas' (CSS pixels; no size, a hidden
 * canvas: the server's default). Through the same camera and of the same
 * aspect as the canvas, the picture frames what the user sees, zoom and pan
 * included. A camera the server cannot draw through (not finite, no
 * direction, a field of view out of range) falls back to the camera's
 * direction, `view` (degrees, as `viewAngles` gives them; null: the server's
 * automatic view), which the server fits to the model. Never both: the
 * server refuses that. `live` and `focus` are dropped: the server ignores
 * them for a picture, and a picture must not look as if it registered the
 * live preview or highlighted a rule.
 */
export function pictureParams(
  preview: PreviewParams,
  view: { azimuth: number; elevation: number } | null,
  canvas: { width: number; height: number },
  camera: CameraParams | null = null,
): PictureParams {
  const { live: _live, focus: _focus, spreadSeeds: _spread, ...rest } = preview;
  const out: PictureParams = { ...rest };
  const usable = usableCamera(camera);
  if (usable) {
    out.camera = usable;
  } else if (view && Number.isFinite(view.azimuth) && Number.isFinite(view.elevation)) {
    // The server takes the elevation in [-90, 90]; rounding error at the poles must not make it refuse.
    out.view = { azimuth: view.azimuth, elevation: Math.max(-90, Math.min(90, view.elevation)) };
  }
  const size = pictureSize(canvas.width, canvas.height);
  if (size) {
    out.width = size.width;
    out.height = size.height;
  }
  return out;
}

/**
 * The file name of a grammar's picture: its last path segment without
 * `.grm`, with `.png` (`file:///w/tree.grm` -> `tree.png`,
 * `untitled:Untitled-1` -> `Untitled-1.png`). Characters that file systems
 * refuse become `_`; a URI without a usable name gives `picture.png`.
 */
export function pictureFileName(uri: string): string {
  // The path without a query or fragment; a scheme without `//` (untitled:) keeps what follows the colon.
  const path = uri.replace(/[?#].*$/, '').replace(/^[a-z][a-z0-9+.-]*:(\/\/[^/]*)?/i, '');
  let last = path.split(/[/\\]/).pop() ?? '';
  try {
    last = decodeURIComponent(last);
  } catch {
    // A malformed escape: the name as written.
  }
  const stem = last
    .replace(/\.grm$/i, '')
    .replace(/[<>:"/\\|?*\u0000-\u001f]/g, '_')
    .trim();
  return `${stem && stem !== '.' && stem !== '..' ? stem : 'picture'}.png`;
}

/** The first bytes of every PNG file. */
const PNG_SIGNATURE = [0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a];

/** The width and height a PNG's header (IHDR, bytes 16..24, big-endian) says; null for bytes that are not a PNG. */
export function pngSize(bytes: Uint8Array): { width: number; height: number } | null {
  if (bytes.length < 24 || PNG_SIGNATURE.some((b, i) => bytes[i] !== b)) return null;
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  return { width: view.getUint32(16), height: view.getUint32(20) };
}

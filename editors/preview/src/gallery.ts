// The preview's gallery: thumbnails of the models of nine seeds from a
// start, one of them chosen as the seed.

import { $ } from './dom.js';
import type { App } from './main.js';
import { decodePreview } from './protocol.js';
import { ThumbnailRenderer } from './scene.js';

export class Gallery {
  private thumbs: ThumbnailRenderer | null = null;
  private start = 0;
  private token = 0;

  constructor(private readonly app: App) {}

  /** Wire its part of the page (listeners on its buttons and fields). */
  wire(): void {
    $('gallery-open').addEventListener('click', () => this.open(this.app.state.currentSeed ?? 0));
    $('gallery-more').addEventListener('click', () => this.open(this.start + 9));
    $('gallery-close').addEventListener('click', () => this.close());
  }

  private async open(start: number): Promise<void> {
    const token = ++this.token;
    this.start = start;
    $('gallery').hidden = false;
    $('gallery-range').textContent = `seeds ${start} to ${start + 8}`;
    const grid = $('gallery-grid');
    grid.replaceChildren();
    this.thumbs ??= new ThumbnailRenderer(160);
    const cam = this.app.scene.camera.position.clone().sub(this.app.scene.controls.target);
    for (let i = 0; i < 9; i++) {
      const seed = start + i;
      const fig = document.createElement('figure');
      fig.className = seed === this.app.state.currentSeed ? 'current' : '';
      fig.dataset.seed = String(seed);
      const img = document.createElement('img');
      img.alt = `seed ${seed}`;
      const cap = document.createElement('figcaption');
      cap.textContent = `seed ${seed}…`;
      fig.append(img, cap);
      fig.addEventListener('click', () => {
        this.app.state.setSeed(seed);
        this.close();
        this.app.regrow();
      });
      grid.append(fig);
    }
    for (let i = 0; i < 9; i++) {
      if (token !== this.token) return;
      const seed = start + i;
      const fig = grid.children[i] as HTMLElement;
      const cap = fig.querySelector('figcaption') as HTMLElement;
      try {
        // Other seeds are other searches: their results, not the scrubbed generation.
        const r = decodePreview(await this.app.transport.request('preview', { ...this.app.state.previewParams(), seed, focus: undefined, generation: undefined, live: false }));
        if (token !== this.token) return;
        (fig.querySelector('img') as HTMLImageElement).src = this.thumbs.render(r.model, [cam.x, cam.y, cam.z]);
        cap.textContent = `seed ${seed}`;
      } catch (e) {
        cap.textContent = `seed ${seed}: ${(e as Error).message}`;
      }
    }
    // The server's live preview follows the last request: make it the current state again.
    this.app.regrow();
  }

  private close(): void {
    this.token++;
    $('gallery').hidden = true;
  }
}

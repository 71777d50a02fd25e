// The preview's meta-parameter sliders: one per `param` with a range
// (moved, released, reset by a double click), and the params without one.

import { $, formatValue } from './dom.js';
import type { App } from './main.js';

export class Sliders {
  /** The sliders' params and ranges (JSON): sliders are built anew when they change (empty: a new document). */
  paramSignature = '';

  constructor(private readonly app: App) {}

  /** The params that have no slider (no range), said under the sliders. */
  showSkippedParams(names: string[]): void {
    $('params-skipped').textContent = names.length ? `No slider for ${names.join(', ')}: give it a range of numbers (param x = 1 in 0 .. 2).` : '';
  }

  refreshParams(): void {
    const info = this.app.state.paramInfo;
    const sig = JSON.stringify(info.map((p) => [p.name, p.min, p.max]));
    const box = $('params');
    if (sig !== this.paramSignature) {
      this.paramSignature = sig;
      box.replaceChildren();
      if (info.length === 0) {
        box.innerHTML = '<p class="hint">The grammar declares no <code>param</code>.</p>';
      }
      for (const p of info) {
        const row = document.createElement('div');
        row.className = 'param';
        const head = document.createElement('div');
        head.className = 'name';
        const name = document.createElement('span');
        name.textContent = p.name;
        const val = document.createElement('span');
        val.className = 'value';
        head.append(name, val);
        const slider = document.createElement('input');
        slider.type = 'range';
        slider.min = String(p.min);
        slider.max = String(p.max);
        slider.step = String((p.max - p.min) / 200 || 1);
        slider.dataset.param = p.name;
        slider.addEventListener('input', () => {
          this.app.state.setParam(p.name, Number(slider.value));
          val.textContent = formatValue(Number(slider.value));
          // A move of the slider: merged with the next ones while a model is on its way.
          this.app.regrow(performance.now(), false);
        });
        // Released: the last value does not wait for a stale model.
        slider.addEventListener('change', () => this.app.released(performance.now(), false));
        slider.addEventListener('dblclick', () => {
          this.app.state.setParam(p.name, p.default);
          this.refreshParams();
          this.app.regrow();
        });
        row.append(head, slider);
        box.append(row);
      }
    }
    $('write-params').hidden = info.length === 0;
    for (const slider of box.querySelectorAll<HTMLInputElement>('input[type=range]')) {
      const v = this.app.state.paramValue(slider.dataset.param ?? '');
      if (v !== undefined && document.activeElement !== slider) slider.value = String(v);
      const label = slider.parentElement?.querySelector('.value');
      if (label && v !== undefined) label.textContent = formatValue(v);
    }
  }

}

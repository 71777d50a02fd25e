// "Save picture" in the preview: the model of the current state drawn by
// the server through the preview's camera, downloaded (a browser) or saved
// where the extension asked (VS Code).

import { $ } from './dom.js';
import type { App } from './main.js';
import { viewAngles } from './messages.js';
import { pictureFileName, pictureParams } from './picture.js';
import { decodePicture } from './protocol.js';

export class PictureButton {
  constructor(private readonly app: App) {}

  /** Wire its part of the page (listeners on its buttons and fields). */
  wire(): void {
    const picture = $<HTMLButtonElement>('save-picture');
    // Where the PNG goes differs: a browser downloads it, VS Code asks where to save it.
    picture.title =
      this.app.transport.kind === 'vscode'
        ? 'Save a PNG of the model as the view shows it (longer side 1024 px); asks where to save it'
        : 'Download a PNG of the model as the view shows it (longer side 1024 px)';
    picture.addEventListener('click', () => void this.savePicture());
  }

  /**
   * "Save picture": the model of the current state (the parameters of the
   * preview request, so the picture is what the view shows), drawn by the
   * server through the preview's camera (zoom, pan and perspective as
   * shown) in the canvas' shape, longer side 1024 pixels. In a browser the
   * page downloads the PNG; in VS Code the extension has asked where to save
   * it and saved it (a webview cannot download), and says where.
   */
  private async savePicture(): Promise<void> {
    const uri = this.app.state.uri;
    const button = $<HTMLButtonElement>('save-picture');
    if (!uri || button.disabled) return;
    button.disabled = true;
    this.app.debug.pictureError = null;
    this.app.setStatus('making the picture…');
    try {
      await this.app.prepareRequest();
      const v = this.app.scene.view();
      const params = pictureParams(this.app.state.previewParams(), viewAngles(...v.direction), v, v.camera);
      const r = decodePicture(await this.app.transport.request('picture', params));
      const name = pictureFileName(uri);
      // A scrubbed search: the picture is of the generation shown, and says so.
      const generation = params.generation;
      const at = generation !== undefined ? `, generation ${generation + 1}` : '';
      if (r.png) {
        download(r.png, name);
        this.app.setStatus(`picture ${name} (${r.width}×${r.height}, seed ${r.seed}${at}) downloaded`);
      } else {
        this.app.setStatus(r.saved ? `picture saved to ${r.saved} (${r.width}×${r.height}, seed ${r.seed}${at})` : 'picture not saved');
      }
      this.app.debug.pictures++;
      this.app.debug.lastPicture = { name, width: r.width, height: r.height, ...(generation !== undefined ? { generation } : {}), ...(r.png ? {} : { saved: r.saved }) };
    } catch (e) {
      // Refused (e.g. the program has errors): said in the status line; the model on screen stays as it is.
      const msg = String((e as Error).message ?? e);
      this.app.debug.pictureError = msg;
      this.app.setStatus(`no picture: ${msg.split('\n')[0]}`, true);
      $('status-text').title = msg;
    } finally {
      button.disabled = false;
    }
  }
}

/** Download bytes as a file: a click on a link to a blob with `download` set (browsers; not in a VS Code webview). */
function download(bytes: Uint8Array, name: string): void {
  // A copy into a fresh ArrayBuffer: Blob takes no view of a buffer that could be shared.
  const url = URL.createObjectURL(new Blob([new Uint8Array(bytes)], { type: 'image/png' }));
  const a = document.createElement('a');
  a.href = url;
  a.download = name;
  a.hidden = true;
  document.body.append(a);
  a.click();
  a.remove();
  // Revoked later, not at once: the browser reads the blob after the click returns.
  setTimeout(() => URL.revokeObjectURL(url), 60_000);
}

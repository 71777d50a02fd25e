// The preview page's HTML for a webview: the page's own index.html with its
// script and stylesheet pointed at webview URIs and a strict content
// security policy (scripts only with the nonce, no network). Pure, tested.

export interface WebviewHtmlOptions {
  scriptUri: string;
  styleUri: string;
  /** `webview.cspSource`. */
  cspSource: string;
  nonce: string;
}

export function webviewHtml(template: string, o: WebviewHtmlOptions): string {
  const csp = [
    "default-src 'none'",
    `img-src ${o.cspSource} data: blob:`,
    `style-src ${o.cspSource} 'unsafe-inline'`,
    `script-src 'nonce-${o.nonce}'`,
  ].join('; ');
  let html = template.replace('<!--CSP-->', `<meta http-equiv="Content-Security-Policy" content="${csp}">`);
  html = html.replace('href="preview.css"', `href="${o.styleUri}"`);
  html = html.replace('<script src="preview.js"></script>', `<script nonce="${o.nonce}" src="${o.scriptUri}"></script>`);
  if (!html.includes(o.scriptUri) || !html.includes(o.styleUri) || !html.includes('Content-Security-Policy')) {
    throw new Error('the preview page template does not have the expected script, stylesheet and CSP slots');
  }
  return html;
}

/** A nonce: 32 characters from a random source of bytes. */
export function makeNonce(randomBytes: (n: number) => Uint8Array): string {
  const alphabet = 'ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789';
  return Array.from(randomBytes(32), (b) => alphabet[b % alphabet.length]).join('');
}

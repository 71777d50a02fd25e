// The preview page's derivation tree panel (issue 28, item 4): the tree of
// the model shown, read a level at a time (`tree`, the server's grm/tree),
// a picked part's node revealed and selected, a node's rule shown in the
// editor when chosen. The model is tree.ts's, shared with VS Code's view.

import { DerivationTree, type TreeNode } from './tree.js';

/** Children shown per node before "N more" (a repeat can make thousands). */
const MAX_SHOWN = 200;

export class TreePanel {
  private readonly tree: DerivationTree;
  /** Expanded nodes (indices of the current preview's tree). */
  private readonly expanded = new Set<number>();
  private selected: string | null = null;
  private uri = '';

  constructor(
    private readonly list: HTMLElement,
    request: (params: unknown) => Promise<unknown>,
    private readonly choose: (n: TreeNode) => void,
  ) {
    this.tree = new DerivationTree({ request: (_method, params) => request(params) });
  }

  /** The document shown. */
  setDocument(uri: string): void {
    this.uri = uri;
    this.tree.setDocument(uri, undefined);
    this.expanded.clear();
    this.selected = null;
    this.list.replaceChildren();
  }

  /** A new model is shown: its tree is read again (node indices change with it; the selection's key stays). */
  async modelShown(): Promise<void> {
    this.tree.setDocument(this.uri, undefined);
    this.expanded.clear();
    if (this.selected) await this.reveal(this.selected);
    else await this.render();
  }

  /** Reveal and select the node of a picked part's key. */
  async reveal(key: string): Promise<void> {
    const n = await this.tree.find(key).catch(() => null);
    if (!n) return;
    for (let p = this.tree.parentOf(n); p; p = this.tree.parentOf(p)) this.expanded.add(p.node);
    this.selected = key;
    await this.render();
    this.list.querySelector('.tree-row.selected')?.scrollIntoView({ block: 'nearest' });
  }

  /** Draw the expanded part of the tree. */
  async render(): Promise<void> {
    const roots = await this.tree.roots();
    const items: HTMLElement[] = [];
    for (const r of roots) items.push(await this.item(r, 0));
    this.list.replaceChildren(...items);
  }

  private async item(n: TreeNode, depth: number): Promise<HTMLElement> {
    const li = document.createElement('li');
    const row = document.createElement('div');
    row.className = n.key === this.selected ? 'tree-row selected' : 'tree-row';
    row.style.paddingLeft = `${depth * 10}px`;
    row.dataset.key = n.key;
    const twisty = document.createElement('span');
    twisty.className = 'twisty';
    twisty.textContent = n.children === 0 ? '' : this.expanded.has(n.node) ? '▾' : '▸';
    const label = document.createElement('span');
    label.className = 'label';
    label.textContent = n.label;
    label.title = `key ${n.key}${n.range ? `, line ${n.range.start.line + 1}` : ''}`;
    row.append(twisty, label);
    twisty.addEventListener('click', () => {
      if (this.expanded.has(n.node)) this.expanded.delete(n.node);
      else this.expanded.add(n.node);
      void this.render();
    });
    label.addEventListener('click', () => {
      this.selected = n.key;
      this.choose(n);
      void this.render();
    });
    li.append(row);
    if (this.expanded.has(n.node) && n.children > 0) {
      const ul = document.createElement('ul');
      const kids = await this.tree.children(n);
      for (const c of kids.slice(0, MAX_SHOWN)) ul.append(await this.item(c, depth + 1));
      if (kids.length > MAX_SHOWN) {
        const more = document.createElement('li');
        more.className = 'tree-more';
        more.textContent = `… ${kids.length - MAX_SHOWN} more`;
        ul.append(more);
      }
      li.append(ul);
    }
    return li;
  }
}

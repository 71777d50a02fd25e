// The derivation tree of the previewed document, read a level at a time
// from the language server (`grm/tree`, docs/lsp-extensions.md), linked to
// picks (a picked part's key reveals its path) and to the source (each
// node's rule). Shared by VS Code's "grm: Derivation" view (the extension
// adapts it to a TreeDataProvider) and the preview page's tree panel
// (tree-panel.ts); no `vscode` or DOM import.

export interface Position {
  line: number;
  character: number;
}

export interface TreeNode {
  /** Index in the preview's tree (valid for `version`). */
  node: number;
  /** Identity key (8 hex digits). */
  key: string;
  label: string;
  /** How many children it has. */
  children: number;
  uri?: string;
  range?: { start: Position; end: Position };
}

export interface TreeAnswer {
  version: number;
  mode: string;
  node: TreeNode;
  children: TreeNode[];
  path: number[];
}

export interface TreeDeps {
  /** Ask the language server. */
  request(method: string, params: unknown): Promise<unknown>;
}

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

function position(v: unknown): Position | undefined {
  if (!isObject(v) || typeof v.line !== 'number' || typeof v.character !== 'number') return undefined;
  return { line: v.line, character: v.character };
}

/** A node as the server sends it; throws on anything else. */
export function parseTreeNode(v: unknown): TreeNode {
  if (!isObject(v)) throw new Error('grm/tree: a node is not an object');
  const { node, key, label, children } = v;
  if (typeof node !== 'number' || typeof key !== 'string' || typeof label !== 'string' || typeof children !== 'number') {
    throw new Error('grm/tree: a node lacks node, key, label or children');
  }
  const out: TreeNode = { node, key, label, children };
  if (typeof v.uri === 'string') out.uri = v.uri;
  if (isObject(v.range)) {
    const start = position(v.range.start);
    const end = position(v.range.end);
    if (start && end) out.range = { start, end };
  }
  return out;
}

/** A `grm/tree` answer (`null`: no such node). */
export function parseTreeAnswer(v: unknown): TreeAnswer | null {
  if (v === null) return null;
  if (!isObject(v) || typeof v.version !== 'number' || typeof v.mode !== 'string' || !Array.isArray(v.children)) {
    throw new Error('grm/tree: not a tree answer');
  }
  const path = Array.isArray(v.path) ? v.path.filter((x): x is number => typeof x === 'number') : [];
  return { version: v.version, mode: v.mode, node: parseTreeNode(v.node), children: v.children.map(parseTreeNode), path };
}

/**
 * The tree of one document's last preview. Nodes are cached per preview
 * version with their parents, so an editor's tree view can ask for any
 * node's parent (to reveal it) once its path was read.
 */
export class DerivationTree {
  private uri: string | undefined;
  private version: number | undefined;
  private readonly parents = new Map<number, TreeNode | undefined>();
  private readonly kids = new Map<number, TreeNode[]>();
  private root: TreeNode | undefined;

  constructor(private readonly deps: TreeDeps) {}

  /** The document shown; a new preview of it (`version`) drops what was read. */
  setDocument(uri: string, version?: number): void {
    if (uri === this.uri && version === this.version) return;
    this.uri = uri;
    this.version = version;
    this.parents.clear();
    this.kids.clear();
    this.root = undefined;
  }

  get document(): string | undefined {
    return this.uri;
  }

  private async ask(params: Record<string, unknown>): Promise<TreeAnswer | null> {
    if (!this.uri) return null;
    const a = parseTreeAnswer(await this.deps.request('grm/tree', { textDocument: { uri: this.uri }, ...params }));
    if (a && a.version !== this.version) {
      // A newer preview: what was read belongs to the old tree.
      this.parents.clear();
      this.kids.clear();
      this.root = undefined;
      this.version = a.version;
    }
    return a;
  }

  private remember(a: TreeAnswer): void {
    if (!this.parents.has(a.node.node)) this.parents.set(a.node.node, undefined);
    if (a.node.node === 0) this.root = a.node;
    this.kids.set(a.node.node, a.children);
    for (const c of a.children) this.parents.set(c.node, a.node);
  }

  /** The root, alone (the tree view's top level); none without a preview. */
  async roots(): Promise<TreeNode[]> {
    if (this.root) return [this.root];
    try {
      const a = await this.ask({});
      if (!a) return [];
      this.remember(a);
      return [a.node];
    } catch {
      // No preview of the document yet: an empty view.
      return [];
    }
  }

  /**
   * After a new preview of the document: whether what was read is still the
   * server's tree (the same preview version and the same root key; another
   * seed's tree has another root key). The root is asked again; a tree that
   * changed drops what was read and keeps the new root. An editor's view
   * redraws only when this is false, so a preview of the same model (the
   * page regrows to highlight the rule at the cursor) does not redraw the
   * view under a click.
   */
  async stillCurrent(): Promise<boolean> {
    const had = this.root;
    const version = this.version;
    const a = await this.ask({});
    if (!a) return false;
    const same = had !== undefined && a.version === version && a.node.key === had.key;
    if (!same) {
      this.parents.clear();
      this.kids.clear();
      this.root = undefined;
      this.remember(a);
    }
    return same;
  }

  /** A node's children. */
  async children(n: TreeNode): Promise<TreeNode[]> {
    const known = this.kids.get(n.node);
    if (known) return known;
    if (n.children === 0) return [];
    const a = await this.ask({ node: n.node });
    if (!a) return [];
    this.remember(a);
    return a.children;
  }

  /** A node's parent, where its path was read. */
  parentOf(n: TreeNode): TreeNode | undefined {
    return this.parents.get(n.node);
  }

  /** The node with `key` (a pick's), its path read so it can be revealed. */
  async find(key: string): Promise<TreeNode | null> {
    const a = await this.ask({ key });
    if (!a) return null;
    // Read each level down the path (cached levels cost nothing), so
    // every node on it knows its parent.
    for (const i of a.path.slice(0, -1)) {
      if (this.kids.has(i)) continue;
      const level = await this.ask({ node: i });
      if (level) this.remember(level);
    }
    const found = a.path.length > 1 ? this.kids.get(a.path[a.path.length - 2]!)?.find((c) => c.node === a.node.node) : this.root;
    return found ?? a.node;
  }
}

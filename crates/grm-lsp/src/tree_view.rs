//! `grm/tree` (issue 28, item 4): the derivation tree of a document's
//! last preview, a level at a time, for an editor's tree view linked to
//! picks and to the source (docs/lsp-extensions.md, "grm/tree").
//!
//! Derive mode walks `grm_grow::Tree` (one node per module ever made,
//! with the production that rewrote it); shape mode the shape tree
//! (shapes, split/repeat/comp commands, inserts, with the operation that
//! made each). A node is named by its index in the preview's tree (valid
//! for that preview's `version`) and by its identity key, which survives
//! a regrow.

use crate::preview::PickTable;
use crate::{Backend, failed};
use grm_shape::NodeId;
use serde::{Deserialize, Serialize};
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::{Range, TextDocumentIdentifier, Uri};

/// `grm/tree` parameters: the node whose children are asked for (its
/// index; none: the root), or the node with `key` (and the path to it).
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct TreeParams {
    pub text_document: TextDocumentIdentifier,
    #[serde(default)]
    pub node: Option<u32>,
    #[serde(default)]
    pub key: Option<String>,
    /// Also answer [`TreeResult::drawn`]: what of the model shown the
    /// node's subtree drew (for an editor to highlight it).
    #[serde(default)]
    pub drawn: bool,
}

/// What of the model shown a node's subtree drew: its triangles (runs per
/// part, as the preview's `picks` name them) and its bones.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct DrawnOut {
    /// Triples (part, first triangle, triangle count), runs merged where
    /// they meet, by part and first triangle.
    pub triangles: Vec<u32>,
    /// Indices into the preview's bones, ascending.
    pub bones: Vec<u32>,
}

/// A node of the tree.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct TreeNodeOut {
    /// Its index in the preview's tree.
    pub node: u32,
    /// Its identity key (8 hex digits).
    pub key: String,
    /// What it is: a symbol (with the iteration it appeared in, derive
    /// mode), a command's label (`split.x`), `insert:ASSET`.
    pub label: String,
    /// How many children it has.
    pub children: u32,
    /// Where the rule that made it (shape mode: the operation) or that
    /// rewrote it (derive mode: the production) is written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uri: Option<Uri>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<Range>,
}

/// `grm/tree` result.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(rename_all = "camelCase")]
pub struct TreeResult {
    /// The document version the preview was built from.
    pub version: i32,
    /// `derive` or `shape` (sample mode: `derive`, the sampler's tree).
    pub mode: String,
    /// The node asked for.
    pub node: TreeNodeOut,
    /// Its children, in order.
    pub children: Vec<TreeNodeOut>,
    /// With `key`: the nodes from the root to it (indices), for an editor
    /// to reveal it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub path: Vec<u32>,
    /// With `drawn`: what the node's subtree drew.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drawn: Option<DrawnOut>,
}

/// Which nodes lie in the subtree of `at` (itself included), from each
/// node's parent; a parent always precedes its child in both trees.
fn subtree(n: usize, at: u32, parent: impl Fn(usize) -> Option<u32>) -> Vec<bool> {
    let mut inside = vec![false; n];
    for i in 0..n {
        inside[i] =
            i as u32 == at || parent(i).is_some_and(|p| (p as usize) < i && inside[p as usize]);
    }
    inside
}

/// The triangles and bones whose module `inside` holds (`module`: a pick's
/// or bone's module to whether it is inside).
fn drawn(t: &PickTable, inside: &dyn Fn(u32) -> bool) -> DrawnOut {
    let mut out = DrawnOut::default();
    for (part, runs) in t.parts.iter().enumerate() {
        let mut open: Option<(u32, u32)> = None;
        for &(first, count, module, _) in runs {
            if !inside(module) {
                continue;
            }
            match &mut open {
                Some((f, c)) if *f + *c == first => *c += count,
                _ => {
                    if let Some((f, c)) = open.take() {
                        out.triangles.extend([part as u32, f, c]);
                    }
                    open = Some((first, count));
                }
            }
        }
        if let Some((f, c)) = open {
            out.triangles.extend([part as u32, f, c]);
        }
    }
    out.bones = (0..t.bones.len() as u32)
        .filter(|&b| inside(t.bones[b as usize].0))
        .collect();
    out
}

fn key_text(k: u32) -> String {
    grm_grow::json::key_text(k)
}

/// The answer for one table.
fn answer(t: &PickTable, params: &TreeParams) -> Option<TreeResult> {
    let key = params
        .key
        .as_deref()
        .map(|k| grm_edits::file::parse_key(k.trim()));
    if let Some(shape) = &t.shape {
        let tree = shape.tree();
        let at = match key {
            Some(k) => NodeId(tree.nodes().iter().position(|n| Some(n.key) == k)? as u32),
            None => NodeId(params.node.unwrap_or(0)),
        };
        tree.node(at)?;
        let out = |id: NodeId| -> Option<TreeNodeOut> {
            let n = tree.node(id)?;
            let (uri, range) = match shape.made_range(id) {
                Some((u, r)) => (Some(u), Some(r)),
                None => (None, None),
            };
            Some(TreeNodeOut {
                node: id.0,
                key: key_text(n.key),
                label: tree.label(shape.program(), id),
                children: tree.children(id).count() as u32,
                uri,
                range,
            })
        };
        let path = if key.is_some() {
            tree.path(at).into_iter().map(|p| p.0).collect()
        } else {
            Vec::new()
        };
        let drawn = params.drawn.then(|| {
            let nodes = tree.nodes();
            let inside = subtree(nodes.len(), at.0, |i| {
                tree.parent(NodeId(i as u32)).map(|p| p.0)
            });
            drawn(t, &|m| inside.get(m as usize) == Some(&true))
        });
        return Some(TreeResult {
            version: t.version,
            mode: "shape".into(),
            node: out(at)?,
            children: tree.children(at).filter_map(out).collect(),
            path,
            drawn,
        });
    }
    let (tree, _) = t.tree.as_deref()?;
    let n = tree.nodes.len();
    let at = match key {
        Some(k) => tree.nodes.iter().position(|x| Some(x.key) == k)? as u32,
        None => params.node.unwrap_or(0),
    };
    if at as usize >= n {
        return None;
    }
    // Children by parent, in order (one pass over the nodes).
    let kids: Vec<u32> = (0..n as u32)
        .filter(|&i| tree.nodes[i as usize].parent == Some(at))
        .collect();
    let out = |i: u32| -> TreeNodeOut {
        let x = &tree.nodes[i as usize];
        let label = match x.symbol.and_then(|s| t.symbols.get(s as usize)) {
            Some(s) => format!("{s} (iteration {})", x.iteration),
            None => "axiom".to_string(),
        };
        let origin = x.production.and_then(|p| t.origins.get(p as usize));
        TreeNodeOut {
            node: i,
            key: key_text(x.key),
            label,
            children: 0,
            uri: origin.map(|o| o.uri.clone()),
            range: origin.map(|o| o.range),
        }
    };
    // Each node's number of children: one pass.
    let mut counts = vec![0u32; n];
    for x in &tree.nodes {
        if let Some(p) = x.parent {
            counts[p as usize] += 1;
        }
    }
    let children: Vec<TreeNodeOut> = kids
        .iter()
        .map(|&i| TreeNodeOut {
            children: counts[i as usize],
            ..out(i)
        })
        .collect();
    let mut node = out(at);
    node.children = kids.len() as u32;
    let path = if key.is_some() {
        let mut p = vec![at];
        let mut i = at;
        while let Some(parent) = tree.nodes[i as usize].parent {
            p.push(parent);
            i = parent;
        }
        p.reverse();
        p
    } else {
        Vec::new()
    };
    let drawn = params.drawn.then(|| {
        let inside = subtree(n, at, |i| tree.nodes[i].parent);
        drawn(t, &|m| {
            tree.node_of_module(m)
                .is_some_and(|x| inside.get(x as usize) == Some(&true))
        })
    });
    Some(TreeResult {
        version: t.version,
        mode: "derive".into(),
        node,
        children,
        path,
        drawn,
    })
}

impl Backend {
    /// `grm/tree`: a node of the last preview's derivation tree and its
    /// children; `null` when there is no such node.
    pub async fn tree(&self, params: TreeParams) -> Result<Option<TreeResult>> {
        self.with_picks(&params.text_document.uri, |t| {
            if t.shape.is_none() && t.tree.is_none() {
                return Err(failed("this preview recorded no derivation tree"));
            }
            Ok(answer(t, &params))
        })
    }
}

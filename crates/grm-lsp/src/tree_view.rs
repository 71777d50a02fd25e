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
use crate::{Backend, convert, failed};
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
        return Some(TreeResult {
            version: t.version,
            mode: "shape".into(),
            node: out(at)?,
            children: tree.children(at).filter_map(out).collect(),
            path,
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
    Some(TreeResult {
        version: t.version,
        mode: "derive".into(),
        node,
        children,
        path,
    })
}

impl Backend {
    /// `grm/tree`: a node of the last preview's derivation tree and its
    /// children; `null` when there is no such node.
    pub async fn tree(&self, params: TreeParams) -> Result<Option<TreeResult>> {
        let path =
            convert::path_of(&params.text_document.uri).ok_or_else(|| failed("not a file URI"))?;
        let tables = self
            .shared
            .picks
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let Some(t) = tables.get(&path) else {
            return Err(failed("no preview of this document yet"));
        };
        if t.shape.is_none() && t.tree.is_none() {
            return Err(failed("this preview recorded no derivation tree"));
        }
        Ok(answer(t, &params))
    }
}

//! A persistent vector: the open non-terminals of a particle.
//!
//! A radix tree of branching [`B`] whose nodes are shared through `Arc`.
//! Cloning is O(1) (one reference count); `get` is O(log_B n); `set`,
//! `push` and `pop` copy only the nodes on one root-to-leaf path (at most
//! `B` entries per level) and share everything else with the vector they
//! came from. So a particle that expands one open non-terminal and opens a
//! few new ones copies a handful of small nodes, never the list of its
//! ancestors' open symbols, and the particles that share an ancestor share
//! its list.
//!
//! Each tree node is a single allocation (an `Arc<[T]>`).
//!
//! Element order is insertion order, except that [`PVec::swap_remove`]
//! moves the last element into the hole (order only has to be
//! deterministic: the sampler picks an index with a seeded draw).

use std::sync::Arc;

/// Branching factor (entries per node).
pub const B: usize = 16;
const BITS: u32 = 4;
const MASK: usize = B - 1;

/// A tree node: one allocation holding its entries (clones of the entries
/// are what a path copy costs).
#[derive(Debug)]
enum Node<T> {
    Leaf(Arc<[T]>),
    Inner(Arc<[Node<T>]>),
}

impl<T> Clone for Node<T> {
    fn clone(&self) -> Self {
        match self {
            Node::Leaf(a) => Node::Leaf(Arc::clone(a)),
            Node::Inner(a) => Node::Inner(Arc::clone(a)),
        }
    }
}

/// A persistent vector (see the module documentation).
#[derive(Debug)]
pub struct PVec<T> {
    root: Node<T>,
    len: usize,
    /// `BITS` times the height of the tree (0: the root is a leaf).
    shift: u32,
}

impl<T> Clone for PVec<T> {
    fn clone(&self) -> Self {
        PVec {
            root: self.root.clone(),
            len: self.len,
            shift: self.shift,
        }
    }
}

impl<T: Clone> Default for PVec<T> {
    fn default() -> Self {
        PVec::new()
    }
}

impl<T: Clone> PVec<T> {
    /// An empty vector.
    pub fn new() -> PVec<T> {
        PVec {
            root: Node::Leaf(Arc::from(Vec::new())),
            len: 0,
            shift: 0,
        }
    }

    /// Bytes of one root-to-leaf path: what a `set`, `push` or `pop`
    /// copies, so what a modified vector owns beyond the one it came from.
    pub fn path_bytes(&self) -> usize {
        (self.shift / BITS + 1) as usize * B * std::mem::size_of::<T>().max(1)
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Element `i`, or `None` past the end.
    pub fn get(&self, i: usize) -> Option<&T> {
        if i >= self.len {
            return None;
        }
        let mut node = &self.root;
        let mut shift = self.shift;
        loop {
            match node {
                Node::Leaf(v) => return v.get(i & MASK),
                Node::Inner(c) => {
                    node = c.get((i >> shift) & MASK)?;
                    shift = shift.saturating_sub(BITS);
                }
            }
        }
    }

    /// How many elements a tree of this height holds.
    fn capacity(&self) -> usize {
        1usize << (self.shift + BITS)
    }

    /// A new vector with `value` appended.
    pub fn push(&self, value: T) -> PVec<T> {
        if self.len == self.capacity() {
            // The tree is full: a new root over the old one and a new path.
            let path = new_path(self.shift, value);
            return PVec {
                root: Node::Inner(Arc::from([self.root.clone(), path])),
                len: self.len + 1,
                shift: self.shift + BITS,
            };
        }
        PVec {
            root: push_rec(&self.root, self.shift, self.len, value),
            len: self.len + 1,
            shift: self.shift,
        }
    }

    /// A new vector with element `i` replaced (`None` past the end).
    pub fn set(&self, i: usize, value: T) -> Option<PVec<T>> {
        if i >= self.len {
            return None;
        }
        Some(PVec {
            root: set_rec(&self.root, self.shift, i, value),
            len: self.len,
            shift: self.shift,
        })
    }

    /// A new vector without the last element, and that element.
    pub fn pop(&self) -> Option<(PVec<T>, T)> {
        if self.len == 0 {
            return None;
        }
        let last = self.get(self.len - 1)?.clone();
        let i = self.len - 1;
        let (mut root, mut shift) = match pop_rec(&self.root, self.shift, i) {
            Some(r) => (r, self.shift),
            None => (Node::Leaf(Arc::from(Vec::new())), 0),
        };
        // Collapse a root with a single child.
        loop {
            let only = match &root {
                Node::Inner(c) if c.len() == 1 => c[0].clone(),
                _ => break,
            };
            root = only;
            shift -= BITS;
        }
        Some((
            PVec {
                root,
                len: self.len - 1,
                shift,
            },
            last,
        ))
    }

    /// A new vector without element `i` (the last element takes its place),
    /// and that element.
    pub fn swap_remove(&self, i: usize) -> Option<(PVec<T>, T)> {
        if i >= self.len {
            return None;
        }
        let removed = self.get(i)?.clone();
        let (popped, last) = self.pop()?;
        if i == popped.len() {
            return Some((popped, removed));
        }
        Some((popped.set(i, last)?, removed))
    }

    /// The elements in order.
    pub fn iter(&self) -> impl Iterator<Item = &T> + '_ {
        (0..self.len).filter_map(move |i| self.get(i))
    }
}

fn new_path<T>(shift: u32, value: T) -> Node<T> {
    let mut node = Node::Leaf(Arc::from([value]));
    let mut s = 0;
    while s < shift {
        node = Node::Inner(Arc::from([node]));
        s += BITS;
    }
    node
}

/// `items` with entry `k` replaced by `value` (one allocation).
fn replaced<U: Clone>(items: &[U], k: usize, value: U) -> Arc<[U]> {
    let mut value = Some(value);
    items
        .iter()
        .enumerate()
        .map(|(j, x)| match value.take_if(|_| j == k) {
            Some(v) => v,
            None => x.clone(),
        })
        .collect()
}

fn push_rec<T: Clone>(node: &Node<T>, shift: u32, i: usize, value: T) -> Node<T> {
    match node {
        Node::Leaf(v) => Node::Leaf(v.iter().cloned().chain(std::iter::once(value)).collect()),
        Node::Inner(c) => {
            let k = (i >> shift) & MASK;
            match c.get(k) {
                Some(child) => {
                    let child = push_rec(child, shift - BITS, i, value);
                    Node::Inner(replaced(c, k, child))
                }
                None => {
                    let path = new_path(shift - BITS, value);
                    Node::Inner(c.iter().cloned().chain(std::iter::once(path)).collect())
                }
            }
        }
    }
}

fn set_rec<T: Clone>(node: &Node<T>, shift: u32, i: usize, value: T) -> Node<T> {
    match node {
        Node::Leaf(v) => Node::Leaf(replaced(v, i & MASK, value)),
        Node::Inner(c) => {
            let k = (i >> shift) & MASK;
            match c.get(k) {
                Some(child) => {
                    let child = set_rec(child, shift.saturating_sub(BITS), i, value);
                    Node::Inner(replaced(c, k, child))
                }
                None => node.clone(),
            }
        }
    }
}

/// Remove element `i` (the last one); `None` when the node becomes empty.
fn pop_rec<T: Clone>(node: &Node<T>, shift: u32, i: usize) -> Option<Node<T>> {
    match node {
        Node::Leaf(v) => {
            if v.len() <= 1 {
                return None;
            }
            Some(Node::Leaf(Arc::from(&v[..v.len() - 1])))
        }
        Node::Inner(c) => {
            let k = (i >> shift) & MASK;
            let child = c
                .get(k)
                .and_then(|child| pop_rec(child, shift.saturating_sub(BITS), i));
            let out: Arc<[Node<T>]> = match child {
                Some(child) => replaced(c, k, child),
                None => Arc::from(&c[..k.min(c.len())]),
            };
            if out.is_empty() {
                None
            } else {
                Some(Node::Inner(out))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every operation against a plain `Vec`, including the versions kept
    /// from before each operation (persistence).
    #[test]
    fn matches_a_vec_and_keeps_old_versions() {
        let mut model: Vec<u32> = Vec::new();
        let mut v: PVec<u32> = PVec::new();
        let mut history: Vec<(PVec<u32>, Vec<u32>)> = Vec::new();
        let mut x = 12345u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        for step in 0..6000 {
            let r = next();
            let op = r % 10;
            if op < 6 || model.is_empty() {
                model.push(step);
                v = v.push(step);
            } else if op < 8 {
                let i = (next() as usize) % model.len();
                let removed = model.swap_remove(i);
                let (v2, got) = v.swap_remove(i).expect("in range");
                assert_eq!(got, removed);
                v = v2;
            } else if op < 9 {
                let i = (next() as usize) % model.len();
                model[i] = step + 100_000;
                v = v.set(i, step + 100_000).expect("in range");
            } else {
                let last = model.pop();
                let (v2, got) = v.pop().expect("non-empty");
                assert_eq!(Some(got), last);
                v = v2;
            }
            assert_eq!(v.len(), model.len());
            if step % 97 == 0 {
                history.push((v.clone(), model.clone()));
            }
        }
        // Grow past two levels and shrink back to empty.
        for k in 0..5000 {
            model.push(k);
            v = v.push(k);
        }
        let collected: Vec<u32> = v.iter().copied().collect();
        assert_eq!(collected, model);
        while let Some(last) = model.pop() {
            let (v2, got) = v.pop().expect("non-empty");
            assert_eq!(got, last);
            v = v2;
        }
        assert!(v.is_empty());
        assert!(v.pop().is_none());
        assert!(v.get(0).is_none());
        // Old versions are untouched.
        for (old, m) in history {
            let got: Vec<u32> = old.iter().copied().collect();
            assert_eq!(got, m);
        }
    }

    #[test]
    fn out_of_range_is_none() {
        let v = PVec::new().push(1).push(2);
        assert!(v.get(2).is_none());
        assert!(v.set(2, 9).is_none());
        assert!(v.swap_remove(2).is_none());
        let (w, x) = v.swap_remove(0).expect("in range");
        assert_eq!(x, 1);
        assert_eq!(w.iter().copied().collect::<Vec<_>>(), vec![2]);
    }
}

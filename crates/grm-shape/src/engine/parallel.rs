//! The parallel derivation: the top of the tree on the calling thread,
//! its cut shapes' subtrees as jobs on the workers (each from its root's
//! ancestry and replay state), and the jobs' slices spliced in where the
//! one-thread derivation would have written them.

use super::*;

/// The size past which the top of the tree is not derived deeper for
/// more parallelism (each deepening derives the top again).
const TOP_NODES: usize = 4096;

/// A parallel job's root: the node, its outline, its ancestors' tags and
/// keys, and with a plan of edits its replay state.
type JobRoot = (Node, Option<Arc<Outline>>, Ancestry, Option<Carried>);

impl Engine<'_> {
    /// Derive with `threads` workers: the top of the tree here, deep
    /// enough to give each worker several subtrees, then the subtrees on
    /// the workers, then the slices spliced in, in the tree's order.
    pub(super) fn parallel(
        &self,
        root: Node,
        root_outline: Option<Arc<Outline>>,
        threads: usize,
    ) -> Result<Job, ShapeError> {
        let max = self.limits.max_nodes;
        let never = AtomicBool::new(false);
        let mut cut = 1;
        let mut top = loop {
            let top = self
                .run(
                    root,
                    root_outline.clone(),
                    Some(cut),
                    max,
                    &never,
                    &Ancestry::default(),
                    None,
                )
                .map_err(|Overflow| ShapeError::TooManyShapes { max })?;
            // Deep enough for four subtrees per worker; but never derive a
            // big top again and again (a narrow grammar): past `TOP_NODES`
            // the top is what it is.
            if top.cut.is_empty()
                || top.cut.len() >= 4 * threads
                || top.nodes.len() >= TOP_NODES
                || cut >= 32
            {
                break top;
            }
            cut += 1;
        };
        let budget = max.saturating_sub(top.nodes.len());
        let uses = &self.program.exprs.uses;
        // The edits' semantic queries read the tagged commands above a
        // job's root too.
        let needs_ancestry =
            uses.tags || !uses.queried.is_empty() || self.edits.is_some_and(EditPlan::has_semantic);
        let roots: Vec<JobRoot> = top
            .cut
            .iter()
            .enumerate()
            .map(|(c, &(i, _))| {
                let n = top.nodes[i as usize];
                let mut a = Ancestry::default();
                if needs_ancestry {
                    ancestry(&top.nodes, i as usize, &mut a.tags, &mut a.keys);
                }
                (
                    n,
                    n.geometry
                        .outline_id()
                        .and_then(|o| top.outlines.get(o.0 as usize).cloned()),
                    a,
                    top.cut_carried.get(c).copied(),
                )
            })
            .collect();
        let next = AtomicUsize::new(0);
        let stop = AtomicBool::new(false);
        let workers = threads.min(roots.len()).max(1);
        let done: Vec<Vec<(usize, Result<Job, Overflow>)>> = std::thread::scope(|sc| {
            let handles: Vec<_> = (0..workers)
                .map(|_| {
                    sc.spawn(|| {
                        let mut mine = Vec::new();
                        loop {
                            let j = next.fetch_add(1, Ordering::Relaxed);
                            let Some((r, o, a, carried)) = roots.get(j) else {
                                break;
                            };
                            let mut r = *r;
                            r.parent_offset = 0;
                            let result =
                                self.run(r, o.clone(), None, budget + 1, &stop, a, *carried);
                            if result.is_err() {
                                stop.store(true, Ordering::Relaxed);
                            }
                            mine.push((j, result));
                        }
                        mine
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_default())
                .collect()
        });
        let mut jobs: Vec<Option<Job>> = (0..roots.len()).map(|_| None).collect();
        for (j, r) in done.into_iter().flatten() {
            match r {
                Ok(job) => jobs[j] = Some(job),
                Err(Overflow) => return Err(ShapeError::TooManyShapes { max }),
            }
        }
        let mut jobs: Vec<Job> = match jobs.into_iter().collect::<Option<Vec<Job>>>() {
            Some(j) => j,
            // A worker that died (it cannot: the engine does not panic).
            None => return Err(ShapeError::TooManyShapes { max }),
        };
        let total = top.nodes.len() + jobs.iter().map(|j| j.nodes.len() - 1).sum::<usize>();
        if total > max {
            return Err(ShapeError::TooManyShapes { max });
        }
        // New index of each top node: shifted by the slices spliced before it.
        let mut shift = vec![0u32; top.nodes.len() + 1];
        {
            let mut add = 0u32;
            let mut c = 0;
            for (i, s) in shift.iter_mut().enumerate() {
                while c < top.cut.len() && top.cut[c].1 as usize == i {
                    add += jobs[c].nodes.len() as u32 - 1;
                    c += 1;
                }
                *s = add;
            }
        }
        // A cut shape whose rule made nothing takes its final state from
        // its job's root before the top's outlines are renumbered (so the
        // table stays in node order).
        for (c, &(i, _)) in top.cut.iter().enumerate() {
            let root = &jobs[c].nodes[0];
            if root.children_len == 0
                && let Some(n) = top.nodes.get_mut(i as usize)
            {
                let g = resolve(&jobs[c].outlines, root.geometry);
                n.scope = root.scope;
                set_geometry(n, &mut top.outlines, &g);
            }
        }
        let new = |i: usize| i as u32 + shift[i];
        let mut out: Vec<Node> = Vec::with_capacity(total);
        let mut outlines: Vec<Arc<Outline>> = Vec::new();
        let mut failures: Vec<(u32, ShapeError)> = Vec::new();
        for (i, e) in top.failures {
            failures.push((new(i as usize), e));
        }
        // The replay's removed shapes and hits, renumbered likewise (the
        // jobs' in `splice`).
        let mut removed: Vec<u32> = top.removed.iter().map(|&i| new(i as usize)).collect();
        let mut hits: Vec<(u32, u32)> = top
            .hits
            .iter()
            .map(|&(id, i)| (id, new(i as usize)))
            .collect();
        let mut c = 0;
        let mut starts = vec![0u32; top.cut.len()];
        for (i, mut n) in top.nodes.iter().copied().enumerate() {
            while c < top.cut.len() && top.cut[c].1 as usize == i {
                starts[c] = splice(
                    &mut out,
                    &mut outlines,
                    &mut jobs[c],
                    new(top.cut[c].0 as usize),
                    &mut failures,
                    &mut removed,
                    &mut hits,
                );
                c += 1;
            }
            renumber(&mut n, &top.outlines, &mut outlines);
            let here = new(i);
            if i > 0 {
                n.parent_offset = here - new(i - n.parent_offset as usize);
            }
            if n.children_len > 0 {
                n.children_offset = new(i + n.children_offset as usize) - here;
            }
            out.push(n);
        }
        while c < top.cut.len() {
            starts[c] = splice(
                &mut out,
                &mut outlines,
                &mut jobs[c],
                new(top.cut[c].0 as usize),
                &mut failures,
                &mut removed,
                &mut hits,
            );
            c += 1;
        }
        // The cut shapes take their jobs' roots (the alternative applied,
        // their blocks).
        for (c, &(i, _)) in top.cut.iter().enumerate() {
            let r = new(i as usize) as usize;
            let root = &jobs[c].roots_kind;
            out[r].kind = root.0;
            out[r].attrs = jobs[c].root_attrs;
            out[r].key = jobs[c].root_key;
            out[r].children_len = root.1;
            out[r].children_offset = if root.1 > 0 { starts[c] - r as u32 } else { 0 };
        }
        Ok(Job {
            hits,
            removed,
            cut_carried: Vec::new(),
            nodes: out,
            outlines,
            failures,
            cut: Vec::new(),
            roots_kind: (root.kind, 0),
            root_attrs: root.attrs,
            root_key: root.key,
            ordered: true,
        })
    }
}

/// Append a job's slice (its nodes but the root) to `out`; `root` is the
/// cut shape's index in `out`'s numbering.
/// Returns where the slice starts.
fn splice(
    out: &mut Vec<Node>,
    outlines: &mut Vec<Arc<Outline>>,
    job: &mut Job,
    root: u32,
    failures: &mut Vec<(u32, ShapeError)>,
    removed: &mut Vec<u32>,
    hits: &mut Vec<(u32, u32)>,
) -> u32 {
    let base = out.len() as u32; // job index k goes to base + k - 1
    let at = |k: u32| if k == 0 { root } else { base + k - 1 };
    job.roots_kind = (job.nodes[0].kind, job.nodes[0].children_len);
    job.root_attrs = job.nodes[0].attrs;
    job.root_key = job.nodes[0].key;
    for (k, e) in job.failures.drain(..) {
        failures.push((at(k), e));
    }
    removed.extend(job.removed.iter().map(|&k| at(k)));
    hits.extend(job.hits.iter().map(|&(id, k)| (id, at(k))));
    for (k, mut n) in job.nodes.drain(..).enumerate().skip(1) {
        renumber(&mut n, &job.outlines, outlines);
        if k as u32 == n.parent_offset {
            n.parent_offset = base + k as u32 - 1 - root;
        }
        out.push(n);
    }
    base
}

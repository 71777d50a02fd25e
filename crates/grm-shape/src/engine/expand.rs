//! The rule run: one shape's rule, its operations in order, appending
//! the shape's block to the node array (`Engine::expand`, inlined into the
//! derivation loop of `super`).

use super::*;

impl Engine<'_> {
    /// Run the rule of the shape at `at`, appending its block to `out`.
    /// `Err(None)` is the node limit. (Inlined into its one caller, the
    /// derivation loop: as a call it cost the facade benchmark 5 to 10%.)
    #[inline(always)]
    pub(super) fn expand(
        &self,
        out: &mut Vec<Node>,
        outlines: &mut Vec<Arc<Outline>>,
        at: u32,
        symbol: SymbolId,
        budget: usize,
        s: &mut Scratch,
    ) -> Result<(), Option<ShapeError>> {
        let program = self.program;
        let Some(rule) = program.rule(symbol) else {
            return Ok(());
        };
        let shape = &out[at as usize];
        let key = shape.key;
        let depth = shape.depth;
        let base = shape.scope;
        let inherited = shape.attrs;
        let mut scope = shape.scope;
        let mut geometry = resolve(outlines, shape.geometry);
        // What expressions read of the shape (docs/shapes.md, "Expressions").
        s.tags.clear();
        s.path.clear();
        let uses = &program.exprs.uses;
        if uses.tags || !uses.queried.is_empty() {
            s.path.push(key);
            ancestry(out, at as usize, &mut s.tags, &mut s.path);
            s.tags.extend_from_slice(&s.prefix.tags);
            s.path.extend_from_slice(&s.prefix.keys);
        }
        let cx = Shape {
            seed: self.seed,
            key,
            index: shape.index,
            count: shape.count,
            depth,
            tags: &s.tags,
            path: &s.path,
            queries: self.queries,
        };
        let exprs = &program.exprs;
        let eval = &mut s.eval;
        let mut num = |p: &Param, scope: &Scope, site: &mut Site| -> f32 {
            match *p {
                Param::Const(v) => v,
                Param::Expr(e) => exprs.eval(e, &cx, scope, site, eval),
            }
        };
        let alts = &rule.alternatives;
        let alt = if let Some(k) = s.force.filter(|&k| (k as usize) < alts.len()) {
            // A persistent edit forces the alternative (crate::replay).
            k
        } else if alts.len() == 1 && alts[0].is_plain() {
            0
        } else {
            // The race of `grm_compile::rng` among the alternatives whose
            // condition holds and whose weight is positive: the earliest
            // time over weight wins, the first alternative on a tie.
            let time = |k: usize| race_time(hash(self.seed, 0, key, choice_draw(k as u32)));
            let mut best: Option<(u32, f32, u32)> = None;
            for (k, a) in alts.iter().enumerate() {
                if let Some(c) = a.condition {
                    let mut site = Site::new(k as u32, SITE_CONDITION);
                    let v = num(&Param::Expr(c), &base, &mut site);
                    if v == 0.0 || v.is_nan() {
                        continue;
                    }
                }
                let mut site = Site::new(k as u32, SITE_WEIGHT);
                let w = match num(&a.weight, &base, &mut site) {
                    f32::INFINITY => f32::MAX,
                    w => w,
                };
                if !(w.is_finite() && w > 0.0) {
                    continue;
                }
                let t = time(k);
                if best.is_none_or(|b| race_earlier(t, w, b.0, b.1)) {
                    best = Some((t, w, k as u32));
                }
            }
            match best {
                Some(b) => b.2,
                // No alternative holds: a terminal shape.
                None => return Ok(()),
            }
        };
        out[at as usize].kind = NodeKind::Shape {
            symbol,
            alternative: Some(alt),
        };
        let name = || program.symbols[symbol.0 as usize].name.clone();
        let fail = |e: ShapeError| Err(Some(e));
        let finite = |what: &'static str, v: f32| -> Result<f32, Option<ShapeError>> {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(Some(ShapeError::BadValue {
                    symbol: name(),
                    what,
                    value: v,
                }))
            }
        };
        let max_depth = self.limits.max_depth;
        let too_deep = |d: u32| -> Result<(), Option<ShapeError>> {
            if d > max_depth {
                Err(Some(ShapeError::TooDeep {
                    max: max_depth,
                    symbol: name(),
                }))
            } else {
                Ok(())
            }
        };
        s.stack.clear();
        s.attr_stack.clear();
        let block = out.len();
        // The premixed salts of the children the operations make.
        let salts = &self.salts[symbol.0 as usize][alt as usize];
        {
            for (i, op) in rule.alternatives[alt as usize].ops.iter().enumerate() {
                // Each operation's draws have their own site (the draw
                // index: docs/shapes.md, "Identity").
                let site = &mut Site::new(alt, SITE_OPS + i as u32);
                match op {
                    Op::Extrude(h) => {
                        let h = finite("the extrusion height", num(h, &scope, site))?.max(0.0);
                        geometry = match geometry {
                            Geom::Rect | Geom::Box => Geom::Box,
                            Geom::Polygon(o) | Geom::Prism(o) => Geom::Prism(o),
                            Geom::Edge | Geom::Roof(_) => {
                                return fail(ShapeError::WrongGeometry {
                                    symbol: name(),
                                    op: "extrude",
                                    geometry: geometry.describe(),
                                });
                            }
                        };
                        scope.size.z = h;
                    }
                    Op::Translate(v) => {
                        let v = Vec3::new(
                            finite("a translation", num(&v[0], &scope, site))?,
                            finite("a translation", num(&v[1], &scope, site))?,
                            finite("a translation", num(&v[2], &scope, site))?,
                        );
                        scope = scope.translated(v);
                    }
                    Op::Rotate { axis, degrees } => {
                        let d = finite("a rotation angle", num(degrees, &scope, site))?;
                        scope = scope.rotated(*axis, d);
                    }
                    Op::Size(sz) => {
                        // All three read the scope before the operation.
                        let mut v = [0.0f32; 3];
                        for i in 0..3 {
                            if let Some(p) = &sz[i] {
                                v[i] = finite("a size", num(p, &scope, site))?.max(0.0);
                            }
                        }
                        let mut f = [1.0f64; 3];
                        for i in 0..3 {
                            if sz[i].is_some() {
                                let v = v[i];
                                let old = scope.size[i];
                                f[i] = if old > 0.0 {
                                    f64::from(v) / f64::from(old)
                                } else {
                                    1.0
                                };
                                scope.size[i] = v;
                            }
                        }
                        if let Geom::Roof(o) = &geometry
                            && let Some(r) = o.roof()
                            && f != [1.0; 3]
                        {
                            let roof = r.scaled(f);
                            geometry = Geom::Roof(Arc::new(Outline::with_roof(
                                roof.base_polygons(),
                                roof,
                            )));
                        } else if let Some(o) = geometry.outline()
                            && (f[0] != 1.0 || f[1] != 1.0)
                        {
                            let scaled = o.scaled(f[0], f[1]);
                            geometry = Geom::from_outline(
                                scaled,
                                scope.size.x,
                                scope.size.y,
                                geometry.is_mass(),
                            );
                        }
                    }
                    Op::Center(axes) => {
                        let reference = s.stack.last().map_or(base, |e| e.0);
                        let delta = reference.center() - scope.center();
                        for (i, &on) in axes.iter().enumerate() {
                            if on {
                                let a = scope.axis([Axis::X, Axis::Y, Axis::Z][i]);
                                scope.origin += a * delta.dot(a);
                            }
                        }
                    }
                    Op::Push => {
                        s.stack.push((scope, geometry.clone()));
                        s.attr_stack.push(s.attrs);
                    }
                    Op::Pop => match s.stack.pop() {
                        Some((sc, g)) => {
                            scope = sc;
                            geometry = g;
                            let saved = s.attr_stack.pop().unwrap_or(inherited);
                            s.attrs = saved;
                        }
                        None => return fail(ShapeError::PopWithoutPush { symbol: name() }),
                    },
                    Op::Offset(d) => {
                        let d = finite("an offset distance", num(d, &scope, site))?;
                        let Some(outline) = crate::component::outline_of(&scope, &geometry) else {
                            return fail(ShapeError::WrongGeometry {
                                symbol: name(),
                                op: "offset",
                                geometry: geometry.describe(),
                            });
                        };
                        match outline.offset(f64::from(d)) {
                            Some(o) => {
                                geometry = Geom::from_outline(
                                    o,
                                    scope.size.x,
                                    scope.size.y,
                                    geometry.is_mass(),
                                );
                            }
                            // Nothing left: the shape makes nothing more.
                            None => break,
                        }
                    }
                    Op::Insert(asset) => {
                        too_deep(depth + 1)?;
                        s.edge += 1;
                        let here = out.len() as u32;
                        out.push(node(
                            NodeKind::Insert { asset: *asset },
                            scope,
                            intern(outlines, &geometry),
                            child_key_premixed(key, salts[i]),
                            s.edge,
                            depth + 1,
                            here - at,
                            s.attrs,
                        ));
                    }
                    Op::Emit(sym) => {
                        too_deep(depth + 1)?;
                        s.edge += 1;
                        let here = out.len() as u32;
                        out.push(node(
                            NodeKind::Shape {
                                symbol: *sym,
                                alternative: None,
                            },
                            scope,
                            intern(outlines, &geometry),
                            child_key_premixed(key, salts[i]),
                            s.edge,
                            depth + 1,
                            here - at,
                            s.attrs,
                        ));
                    }
                    Op::Split(sp) | Op::Repeat(sp) => {
                        let is_repeat = matches!(op, Op::Repeat(_));
                        too_deep(depth + 2)?;
                        s.sizes.clear();
                        s.sizes.extend(
                            sp.parts
                                .iter()
                                .map(|p| p.size.eval(|p| num(p, &scope, site))),
                        );
                        let extent = scope.size[sp.axis.index()];
                        let size_err = |error| {
                            Err(Some(ShapeError::Size {
                                symbol: name(),
                                error,
                            }))
                        };
                        // The layout depends on the op, the extent and the
                        // sizes only: look it up before laying it out.
                        let op_id = std::ptr::from_ref(sp) as usize;
                        let bits = extent.to_bits();
                        let hit = s
                            .memo
                            .iter()
                            .position(|m| m.op == op_id && m.extent == bits && m.sizes == s.sizes);
                        let slot = match hit {
                            Some(i) => i,
                            None => {
                                if s.memo.len() < MEMO {
                                    s.memo.push(Memo::default());
                                }
                                let i = s.memo_next % MEMO.min(s.memo.len());
                                s.memo_next = s.memo_next.wrapping_add(1);
                                let m = &mut s.memo[i];
                                m.op = usize::MAX;
                                let laid = if is_repeat {
                                    repeat_into(
                                        &s.sizes,
                                        extent,
                                        self.limits.max_nodes as u64,
                                        &mut m.layout,
                                    )
                                } else {
                                    m.layout.tiles = 1;
                                    split_into(&s.sizes, extent, &mut m.layout.spans)
                                };
                                match laid {
                                    Ok(()) => {}
                                    Err(SizeError::TooManyTiles { .. }) => return Err(None),
                                    Err(e) => return size_err(e),
                                }
                                m.op = op_id;
                                m.extent = bits;
                                m.sizes.clear();
                                m.sizes.extend_from_slice(&s.sizes);
                                let parts = sp.parts.len() as u32;
                                let tiles = m.layout.tiles;
                                m.kids.clear();
                                m.kids.extend(m.layout.spans.iter().filter_map(|span| {
                                    let target = sp.parts[span.part as usize].target?;
                                    let number = span.tile * parts + span.part + 1;
                                    let th = program.symbols[target.0 as usize].name_hash;
                                    let (index, count) = if is_repeat {
                                        (span.tile + 1, tiles)
                                    } else {
                                        (span.part + 1, parts)
                                    };
                                    Some(Kid {
                                        start: span.start,
                                        len: span.len,
                                        target,
                                        number,
                                        index,
                                        count,
                                        salt: premix(salt(th, number, 0)),
                                    })
                                }));
                                i
                            }
                        };
                        let kids = &s.memo[slot].kids;
                        let command = if is_repeat {
                            Command::Repeat(sp.axis)
                        } else {
                            Command::Split(sp.axis)
                        };
                        s.edge += 1;
                        let cmd_key = child_key_premixed(key, salts[i]);
                        let cmd_at = out.len();
                        out.push(node(
                            NodeKind::Command {
                                command,
                                tag: sp.tag,
                            },
                            scope,
                            intern(outlines, &geometry),
                            cmd_key,
                            s.edge,
                            depth + 1,
                            cmd_at as u32 - at,
                            s.attrs,
                        ));
                        let dir = scope.axis(sp.axis);
                        // A box, rectangle or edge is cut by arithmetic
                        // alone: each part has the same geometry.
                        let same = plain(&geometry);
                        for kid in kids {
                            let g = match same {
                                Some(g) => g,
                                None => {
                                    let Some(g) =
                                        geometry.slab(&scope, sp.axis, kid.start, kid.len)
                                    else {
                                        continue;
                                    };
                                    intern(outlines, &g)
                                }
                            };
                            let here = out.len();
                            let mut n = node(
                                NodeKind::Shape {
                                    symbol: kid.target,
                                    alternative: None,
                                },
                                scope.slab_along(dir, sp.axis, kid.start, kid.len),
                                g,
                                child_key_premixed(cmd_key, kid.salt),
                                kid.number,
                                depth + 2,
                                (here - cmd_at) as u32,
                                s.attrs,
                            );
                            (n.index, n.count) = (kid.index, kid.count);
                            out.push(n);
                            if out.len() > budget {
                                return Err(None);
                            }
                        }
                        let len = out.len() - cmd_at - 1;
                        out[cmd_at].children_offset = 1;
                        out[cmd_at].children_len = len as u32;
                    }
                    Op::Roof {
                        kind,
                        angle,
                        overhang,
                    } => {
                        let angle = f64::from(finite("a roof angle", num(angle, &scope, site))?);
                        let d = f64::from(finite("a roof overhang", num(overhang, &scope, site))?);
                        let kind = *kind;
                        match crate::roof::on_shape(&scope, &geometry, true, |o| {
                            crate::roof::build(o, kind, angle, d)
                        }) {
                            Ok((sc, g)) => (scope, geometry) = (sc, g),
                            Err(e) => return fail(roof_error(name(), "roof", &geometry, e)),
                        }
                    }
                    Op::Taper(h) => {
                        let h = f64::from(finite("a taper height", num(h, &scope, site))?.max(0.0));
                        match crate::roof::on_shape(&scope, &geometry, false, |o| {
                            crate::roof::taper(o, h)
                        }) {
                            Ok((sc, g)) => (scope, geometry) = (sc, g),
                            Err(e) => return fail(roof_error(name(), "taper", &geometry, e)),
                        }
                    }
                    Op::Comp(c) => {
                        too_deep(depth + 2)?;
                        let comps = match components(&scope, &geometry, c.target) {
                            Ok(v) => v,
                            Err(NotApplicable) => {
                                return fail(ShapeError::WrongGeometry {
                                    symbol: name(),
                                    op: match c.target {
                                        CompTarget::Faces => "a component split into faces",
                                        CompTarget::Edges => "a component split into edges",
                                    },
                                    geometry: geometry.describe(),
                                });
                            }
                        };
                        s.edge += 1;
                        let cmd_key = child_key_premixed(key, salts[i]);
                        let cmd_at = out.len();
                        out.push(node(
                            NodeKind::Command {
                                command: Command::Comp(c.target),
                                tag: c.tag,
                            },
                            scope,
                            intern(outlines, &geometry),
                            cmd_key,
                            s.edge,
                            depth + 1,
                            cmd_at as u32 - at,
                            s.attrs,
                        ));
                        let case_of = |comp: &crate::component::Component| {
                            c.cases
                                .iter()
                                .position(|k| comp.classes.matches(k.selector))
                        };
                        s.counts.clear();
                        s.counts.resize(c.cases.len() * 2, 0);
                        for comp in &comps {
                            if let Some(k) = case_of(comp) {
                                s.counts[k] += 1;
                            }
                        }
                        for comp in comps {
                            let Some(k) = case_of(&comp) else { continue };
                            let seen = &mut s.counts[c.cases.len() + k];
                            *seen += 1;
                            let index = *seen;
                            let Some(target) = c.cases[k].target else {
                                continue;
                            };
                            let th = program.symbols[target.0 as usize].name_hash;
                            let here = out.len();
                            let mut n = node(
                                NodeKind::Shape {
                                    symbol: target,
                                    alternative: None,
                                },
                                comp.scope,
                                intern(outlines, &comp.geometry),
                                child_key(cmd_key, salt(th, index, k as u32)),
                                index,
                                depth + 2,
                                (here - cmd_at) as u32,
                                s.attrs,
                            );
                            n.case = k as u32;
                            n.selector = Some(c.cases[k].selector);
                            n.count = s.counts[k];
                            out.push(n);
                            if out.len() > budget {
                                return Err(None);
                            }
                        }
                        let len = out.len() - cmd_at - 1;
                        out[cmd_at].children_offset = 1;
                        out[cmd_at].children_len = len as u32;
                    }
                    // A material an edit forces wins (crate::replay).
                    Op::Material(_) if s.keep_material => {}
                    Op::Material(_) | Op::Color(_) | Op::Texture(_) => {
                        let mut rgb = None;
                        if let Op::Color(c) = op {
                            let mut v = [0.0f32; 3];
                            for (x, p) in v.iter_mut().zip(c) {
                                *x = finite("a colour channel", num(p, &scope, site))?;
                            }
                            rgb = Some(v);
                        }
                        // The same attribute set on the same attributes
                        // (every window of a facade setting its glass):
                        // remembered, without the shared table's lock.
                        let key = match (op, rgb) {
                            (Op::Material(m), _) => (0, [m.0, 0, 0]),
                            (Op::Texture(t), _) => (1, [t.0, 0, 0]),
                            (_, c) => (2, c.unwrap_or_default().map(f32::to_bits)),
                        };
                        let id = match s.attr_memo.iter().find(|m| m.0 == s.attrs && m.1 == key) {
                            Some(m) => m.2,
                            None => {
                                let id = self.set_attribute(op, rgb, s.attrs).map_err(Some)?;
                                if s.attr_memo.len() < ATTR_MEMO {
                                    s.attr_memo.push((s.attrs, key, id));
                                } else {
                                    s.attr_memo[s.attr_memo_next] = (s.attrs, key, id);
                                    s.attr_memo_next = (s.attr_memo_next + 1) % ATTR_MEMO;
                                }
                                id
                            }
                        };
                        s.attrs = id;
                    }
                }
            }
            // A shape whose rule made nothing (no successor, command or
            // insert) is a leaf drawn as its rule left it: its node takes
            // the final scope and geometry (docs/shapes.md, "The tree").
            if out.len() == block
                && let Some(n) = out.get_mut(at as usize)
                && !finalize(n, outlines, scope, &geometry)
            {
                s.unordered = true;
            }
            Ok(())
        }
    }
}

/// The error of a roof or taper that could not be made: the roof's own
/// reason, or the geometry that takes none.
fn roof_error(
    symbol: String,
    op: &'static str,
    geometry: &Geom,
    e: Option<crate::roof::RoofError>,
) -> ShapeError {
    match e {
        Some(error) => ShapeError::Roof { symbol, error },
        None => ShapeError::WrongGeometry {
            symbol,
            op,
            geometry: geometry.describe(),
        },
    }
}

/// Give the shape `n`, whose rule made nothing, the scope and geometry its
/// rule left. Returns whether the outline table is still one entry per
/// node in node order ([`set_geometry`]).
#[cold]
#[inline(never)]
fn finalize(n: &mut Node, outlines: &mut Vec<Arc<Outline>>, scope: Scope, g: &Geom) -> bool {
    n.scope = scope;
    set_geometry(n, outlines, g)
}

//! The `layout NAME { ... }` item (issue 29; docs/layout.md): a city
//! layout's layers, bottom to top, and the shape system each parcel grows.
//! Each field is a layer named by its key, except two keys:
//!
//! - `buildings = System;`: the shape system (`mode = shape`) each parcel
//!   grows, its tags passed as the building's meta-parameters;
//! - `seed = N;`: mixed into every building's seed.
//!
//! A layer's value is its source: `grid(nx, ny, dx, dy[, seed])`,
//! `radial(x, y, rings, ring_spacing, spokes[, seed])` (numbers),
//! `geojson("file.geojson")` (relative to the grammar), `lsystem(System)`
//! (a derive system whose turtle path becomes streets) or `edited()` (the
//! artist's layer, kept in `NAME.layout.json`). The sidecar's layer of the
//! same name adds the artist's moves, deletions, protections and
//! assignments. Problems are E0601-E0603 (and E0101, E0102 for names).

use grm_diag::{Code, Diagnostic, Span};
use grm_syntax::ast::{self, Expr, ExprKind, Item, UnaryOp};

use crate::check::Checker;
use crate::program::{Loc, Mode};

/// A checked `layout` item.
#[derive(Clone, Debug, PartialEq)]
pub struct LayoutDef {
    pub name: String,
    /// The layout's name.
    pub loc: Loc,
    /// The whole item.
    pub span: Span,
    /// Bottom to top.
    pub layers: Vec<LayerDef>,
    /// The shape system the parcels grow (an index into `Program::systems`).
    pub buildings: Option<usize>,
    pub seed: u32,
}

/// One layer of a layout.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerDef {
    pub name: String,
    /// The layer's key.
    pub loc: Loc,
    pub source: LayerSource,
}

/// Where a layer's elements come from.
#[derive(Clone, Debug, PartialEq)]
pub enum LayerSource {
    Grid {
        nx: u32,
        ny: u32,
        dx: f64,
        dy: f64,
        seed: u64,
    },
    Radial {
        x: f64,
        y: f64,
        rings: u32,
        ring_spacing: f64,
        spokes: u32,
        seed: u64,
    },
    /// A GeoJSON file as written (relative to the grammar's directory).
    GeoJson(String),
    /// A derive system (an index into `Program::systems`) whose turtle
    /// path becomes streets.
    LSystem(usize),
    /// The artist's layer, all in the sidecar.
    Edited,
}

/// A number literal, negated or not.
fn literal(e: &Expr) -> Option<f64> {
    match &e.kind {
        ExprKind::Number { value, .. } => Some(*value),
        ExprKind::Paren(inner) => literal(inner),
        ExprKind::Unary {
            op: UnaryOp::Neg,
            operand,
        } => literal(operand).map(|v| -v),
        _ => None,
    }
}

impl Checker<'_> {
    /// Check every `layout` item of every file (after the systems, which
    /// its fields name).
    pub(crate) fn layouts(&mut self) {
        let files = self.files;
        for f in files {
            for item in &f.ast.items {
                if let Item::Layout(l) = item {
                    let def = self.layout(f.id, l);
                    self.program.layouts.push(def);
                }
            }
        }
    }

    fn system_named(&mut self, file: grm_diag::FileId, e: &Expr) -> Option<usize> {
        let ExprKind::Name(id) = &e.kind else {
            self.error(
                Diagnostic::new(
                    Code::LayoutSourceArguments,
                    "expected the name of a system",
                    file,
                    e.span,
                    "not a system's name",
                )
                .with_help("write the name of a system of this file or its imports"),
            );
            return None;
        };
        let found = self
            .program
            .systems
            .iter()
            .position(|s| *s.name == *id.name);
        if let Some(i) = found {
            self.program.index.push(
                file,
                id.span,
                crate::index::Def::System(crate::SystemId(i as u32)),
                false,
            );
        } else {
            self.error(
                Diagnostic::new(
                    Code::UnknownName,
                    format!("no system named `{}`", id.name),
                    file,
                    id.span,
                    "unknown system",
                )
                .with_help("a layout names systems of this file or its imports"),
            );
        }
        found
    }

    fn layout(&mut self, file: grm_diag::FileId, l: &ast::LayoutDecl) -> LayoutDef {
        let mut def = LayoutDef {
            name: l.name.name.to_string(),
            loc: Loc::new(file, l.name.span),
            span: l.span,
            layers: Vec::new(),
            buildings: None,
            seed: 0,
        };
        let mut seen: Vec<(&str, Span)> = Vec::new();
        for field in &l.fields {
            let key = field.name.name.as_ref();
            if let Some((_, first)) = seen.iter().find(|(k, _)| *k == key) {
                self.error(
                    Diagnostic::new(
                        Code::DuplicateDefinition,
                        format!("`{key}` is given twice in layout `{}`", l.name.name),
                        file,
                        field.name.span,
                        "given again here",
                    )
                    .with_label(file, *first, "first given here"),
                );
                continue;
            }
            seen.push((key, field.name.span));
            match key {
                "buildings" => {
                    if let Some(i) = self.system_named(file, &field.value) {
                        if self.program.systems[i].mode == Mode::Shape {
                            def.buildings = Some(i);
                        } else {
                            let name = self.program.systems[i].name.clone();
                            self.error(
                                Diagnostic::new(
                                    Code::LayoutWrongSystemMode,
                                    format!("`{name}` is not a shape system: parcels grow shape systems"),
                                    file,
                                    field.value.span,
                                    "not `mode = shape;`",
                                )
                                .with_help("name a system with `mode = shape;` (a building's split grammar)"),
                            );
                        }
                    }
                }
                "seed" => match literal(&field.value) {
                    Some(v) if v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f64 => {
                        def.seed = v as u32;
                    }
                    _ => self.error(
                        Diagnostic::new(
                            Code::LayoutSourceArguments,
                            "a layout's `seed` is a whole number from 0 to 4294967295",
                            file,
                            field.value.span,
                            "not a seed",
                        )
                        .with_help("write a number, e.g. `seed = 7;`"),
                    ),
                },
                _ => {
                    if let Some(source) = self.layer_source(file, &field.value) {
                        def.layers.push(LayerDef {
                            name: key.to_string(),
                            loc: Loc::new(file, field.name.span),
                            source,
                        });
                    }
                }
            }
        }
        def
    }

    fn layer_source(&mut self, file: grm_diag::FileId, e: &Expr) -> Option<LayerSource> {
        let ExprKind::Call { func, args } = &e.kind else {
            self.error(
                Diagnostic::new(
                    Code::LayoutUnknownSource,
                    "a layer's value is its source",
                    file,
                    e.span,
                    "not a layer source",
                )
                .with_help("write `grid(nx, ny, dx, dy)`, `radial(x, y, rings, spacing, spokes)`, `geojson(\"file.geojson\")`, `lsystem(System)` or `edited()`"),
            );
            return None;
        };
        let (min, max, what) = match func.name.as_ref() {
            "grid" => (4, 5, "grid(nx, ny, dx, dy[, seed])"),
            "radial" => (5, 6, "radial(x, y, rings, ring_spacing, spokes[, seed])"),
            "geojson" => (1, 1, "geojson(\"file.geojson\")"),
            "lsystem" => (1, 1, "lsystem(System)"),
            "edited" => (0, 0, "edited()"),
            other => {
                self.error(
                    Diagnostic::new(
                        Code::LayoutUnknownSource,
                        format!("`{other}` is not a layer source"),
                        file,
                        func.span,
                        "unknown source",
                    )
                    .with_help(
                        "the sources are `grid`, `radial`, `geojson`, `lsystem` and `edited`",
                    ),
                );
                return None;
            }
        };
        let wrong = |cx: &mut Self, span: Span, why: String| {
            cx.error(
                Diagnostic::new(Code::LayoutSourceArguments, why, file, span, "here")
                    .with_help(format!("write `{what}`")),
            );
        };
        if args.len() < min || args.len() > max {
            wrong(
                self,
                e.span,
                format!(
                    "`{}` takes {} arguments, not {}",
                    func.name,
                    if min == max {
                        min.to_string()
                    } else {
                        format!("{min} or {max}")
                    },
                    args.len()
                ),
            );
            return None;
        }
        match func.name.as_ref() {
            "geojson" => match &args[0].kind {
                ExprKind::Str(s) if !s.trim().is_empty() => Some(LayerSource::GeoJson(s.clone())),
                _ => {
                    wrong(self, args[0].span, "expected a file name in quotes".into());
                    None
                }
            },
            "lsystem" => {
                let i = self.system_named(file, &args[0])?;
                if self.program.systems[i].mode == Mode::Derive {
                    Some(LayerSource::LSystem(i))
                } else {
                    let name = self.program.systems[i].name.clone();
                    self.error(
                        Diagnostic::new(
                            Code::LayoutWrongSystemMode,
                            format!("`{name}` is not a derive system: streets are grown by an L-system"),
                            file,
                            args[0].span,
                            "not a derive system",
                        )
                        .with_help("name an L-system (no `mode` setting, or `mode = derive;`) whose turtle draws the streets"),
                    );
                    None
                }
            }
            "edited" => Some(LayerSource::Edited),
            name => {
                let mut nums = Vec::new();
                for a in args {
                    match literal(a) {
                        Some(v) if v.is_finite() => nums.push(v),
                        _ => {
                            wrong(self, a.span, "expected a number".into());
                            return None;
                        }
                    }
                }
                let count =
                    |v: f64| (v >= 0.0 && v.fract() == 0.0 && v <= 4096.0).then_some(v as u32);
                let seed = |v: Option<&f64>| match v {
                    None => Some(1),
                    Some(&v) => (v >= 0.0 && v.fract() == 0.0 && v < 9.0e15).then_some(v as u64),
                };
                let at = |i: usize| args[i.min(args.len() - 1)].span;
                if name == "grid" {
                    let (Some(nx), Some(ny)) = (count(nums[0]), count(nums[1])) else {
                        wrong(
                            self,
                            at(0),
                            "the counts are whole numbers from 0 to 4096".into(),
                        );
                        return None;
                    };
                    let Some(seed) = seed(nums.get(4)) else {
                        wrong(self, at(4), "a seed is a whole number, 0 or more".into());
                        return None;
                    };
                    Some(LayerSource::Grid {
                        nx,
                        ny,
                        dx: nums[2],
                        dy: nums[3],
                        seed,
                    })
                } else {
                    let (Some(rings), Some(spokes)) = (count(nums[2]), count(nums[4])) else {
                        wrong(
                            self,
                            at(2),
                            "rings and spokes are whole numbers from 0 to 4096".into(),
                        );
                        return None;
                    };
                    let Some(seed) = seed(nums.get(5)) else {
                        wrong(self, at(5), "a seed is a whole number, 0 or more".into());
                        return None;
                    };
                    Some(LayerSource::Radial {
                        x: nums[0],
                        y: nums[1],
                        rings,
                        ring_spacing: nums[3],
                        spokes,
                        seed,
                    })
                }
            }
        }
    }
}

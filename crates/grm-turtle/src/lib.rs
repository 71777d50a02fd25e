//! `grm-turtle`: turtle interpretation of a module string.
//!
//! Role: the stage between derivation (or the guided sampler) and mesh
//! building. It walks a [`ModuleString`] of one system with the full ABoP
//! turtle (`F f G g + - & ^ \ / | $ [ ] ! ' { . } %`, tropism) plus the
//! Calder-style explicit transforms (`translate rotate rotx roty rotz scale
//! push pop`) and the geometry terminals, and records what they draw.
//!
//! Inputs: the checked [`System`] (its symbol table says which symbol ids
//! are terminals), its [`Settings`] (angle, step, width, tropism,
//! elasticity) and a [`ModuleString`] whose symbols index `system.symbols`.
//!
//! Outputs: an [`Interpretation`]: [`Bone`]s (one per `F`/`G`), geometry
//! [`Instance`]s (one per primitive or mesh terminal, with the full world
//! transform), [`Polygon`]s (from `{ . }`) and the bounds of all of them.
//!
//! Conventions (also in `docs/language.md` section 5):
//! - The turtle state is an affine frame `M` (turtle space to world). Turtle
//!   space has the heading H along local +Y, left L along local +X and up U
//!   along local -Z (so H x L = U). Initially `M` is the identity: H = +Y,
//!   L = +X, U = -Z, at the origin.
//! - Every command multiplies `M` on the right (Calder): `F(l)` is
//!   `M = M * translate(0, l, 0)`, so `scale` affects later moves and
//!   primitives. `+(a)` = `rotz(-a)` (turns H towards L: `F + F` with
//!   angle 90 ends at (1, 1, 0)), `-(a)` = `rotz(a)`, `&(a)` = `rotx(a)`
//!   (pitch down: H towards -U), `^(a)` = `rotx(-a)`, `\(a)` = `roty(a)`,
//!   `/(a)` = `roty(-a)`, `|` = `rotz(180)`. `rotx/roty/rotz/rotate` are
//!   right-handed rotations about turtle-space axes. Angles in degrees.
//! - Tropism (ABoP p. 58): after each `F`/`G`, H is rotated towards the
//!   world vector T by `e * |H x T|` radians about `H x T` (H normalised).
//! - Widths are diameters; a bone's world width is the turtle width times
//!   the frame's lateral scale (mean length of its L and U columns).
//!
//! Invariants: no allocation per module (outputs grow amortised); nothing
//! panics on any module string (malformed strings are a [`TurtleError`],
//! odd parameters are clamped or ignored and counted in [`Warnings`]); a
//! bone's `parent` always has a smaller index than the bone.
//!
//! Frame locality (sample systems): a user (non-terminal) module never moves
//! the turtle. The guided sampler interprets one expansion at a time with
//! [`Interpreter::run_range`] starting from the saved [`Turtle`] of the
//! module it expands; in a flat string user modules are inert.

use std::ops::Range;

use glam::{Affine3A, Mat3A, Vec3, Vec3A};
use grm_derive::ModuleString;
use grm_sema::{MaterialId, MeshId, Settings, System, Terminal};

/// The `origin` of parts whose producing production is not known.
pub const NO_ORIGIN: u32 = u32::MAX;

/// Multiplier of `!` without argument.
pub const SHRINK: f32 = 0.7;

/// The colour table of `'(i)`: index `i` takes entry `i % len`.
pub const PALETTE: [[f32; 3]; 8] = [
    [0.45, 0.32, 0.20], // 0: bark
    [0.30, 0.55, 0.20], // 1: leaf green
    [0.85, 0.75, 0.30], // 2: yellow
    [0.80, 0.25, 0.25], // 3: red
    [0.30, 0.40, 0.80], // 4: blue
    [0.90, 0.90, 0.90], // 5: white
    [0.60, 0.30, 0.70], // 6: purple
    [0.15, 0.15, 0.15], // 7: near black
];

/// What a part is painted with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Paint {
    /// A colour index (`'`), into [`PALETTE`] modulo its length.
    Palette(u32),
    /// An explicit linear RGB colour (`color(r, g, b)`), each in [0, 1].
    Rgb([f32; 3]),
    /// A declared material (`material(m)`).
    Material(MaterialId),
}

impl Default for Paint {
    fn default() -> Self {
        Paint::Palette(0)
    }
}

impl Paint {
    /// The colour of a palette index.
    pub fn palette_color(index: u32) -> [f32; 3] {
        PALETTE[index as usize % PALETTE.len()]
    }
}

/// An axis-aligned bounding box. Empty when `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    /// Grow to contain `p` (non-finite points are ignored).
    #[inline]
    pub fn add(&mut self, p: Vec3) {
        if p.is_finite() {
            self.min = self.min.min(p);
            self.max = self.max.max(p);
        }
    }

    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    pub fn size(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }
}

/// A moving segment (`F` or `G`): the skeleton.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bone {
    /// Turtle position before the move.
    pub base: Vec3,
    /// Turtle position after the move.
    pub tip: Vec3,
    /// The turtle's L axis (unit, world) when the bone was made: a
    /// reference direction for orienting tube rings.
    pub left: Vec3,
    /// The bone that was current in this branch when this one was made.
    pub parent: Option<u32>,
    /// World width (diameter) at the base.
    pub width_base: f32,
    /// World width (diameter) at the tip.
    pub width_tip: f32,
    pub paint: Paint,
    /// Index of the module that made it.
    pub module: u32,
    /// Which production made the module (filled by the caller from a side
    /// table); [`NO_ORIGIN`] by default.
    pub origin: u32,
}

impl Bone {
    pub fn length(&self) -> f32 {
        (self.tip - self.base).length()
    }
}

/// What a geometry instance draws. Every kind is a unit shape in its own
/// space, placed by [`Instance::transform`]:
/// - `Cylinder`, `Cone`: radius 1 at y = 0, height 1 along +Y (the cone's
///   apex at y = 1).
/// - `Sphere`: radius 1 about the origin.
/// - `Box`: `[-0.5, 0.5] x [0, 1] x [-0.5, 0.5]` (sits on the turtle).
/// - `Disc`: radius 1 in the XZ plane, facing +Y (H).
/// - `Mesh`: the OBJ file's coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InstanceKind {
    Cylinder,
    Cone,
    Sphere,
    Box,
    Disc,
    Mesh(MeshId),
}

/// A geometry terminal's output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    pub kind: InstanceKind,
    /// Unit shape to world: the turtle frame times the primitive's size.
    pub transform: Affine3A,
    pub paint: Paint,
    /// The bone current when it was made (what it is attached to).
    pub bone: Option<u32>,
    pub module: u32,
    pub origin: u32,
}

/// A polygon from `{ ... }`: its vertices are
/// `Interpretation::polygon_vertices[first..first + len]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Polygon {
    pub first: u32,
    pub len: u32,
    /// The paint current at `}`.
    pub paint: Paint,
    /// The module `}` that closed it.
    pub module: u32,
    pub origin: u32,
}

/// Things the interpreter tolerated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Warnings {
    /// `]` without a matching `[`: ignored.
    pub unbalanced_pops: u32,
    /// `}` without `{`: ignored.
    pub unbalanced_polygon_ends: u32,
    /// `{` never closed: dropped.
    pub unclosed_polygons: u32,
    /// Polygons closed with fewer than 3 distinct vertices: dropped.
    pub degenerate_polygons: u32,
    /// Bones, instances or vertices with non-finite coordinates: dropped.
    pub non_finite: u32,
    /// `mesh(m)` or `material(m)` with an argument that is not an id.
    pub bad_ids: u32,
}

/// The result of interpreting a string.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Interpretation {
    pub bones: Vec<Bone>,
    pub instances: Vec<Instance>,
    pub polygons: Vec<Polygon>,
    /// The vertices of all polygons, concatenated.
    pub polygon_vertices: Vec<Vec3>,
    /// Bounds of bone ends, instance shapes (their unit boxes transformed;
    /// a mesh counts as its origin) and polygon vertices.
    pub bounds: Aabb,
    pub warnings: Warnings,
}

impl Interpretation {
    /// The vertices of a polygon.
    pub fn vertices(&self, p: &Polygon) -> &[Vec3] {
        let s = p.first as usize;
        let e = s + p.len as usize;
        self.polygon_vertices.get(s..e).unwrap_or(&[])
    }

    /// Set the `origin` of every part from a per-module side table
    /// (`origins[module]`); modules past its end keep [`NO_ORIGIN`].
    pub fn fill_origins(&mut self, origins: &[u32]) {
        let get = |m: u32| origins.get(m as usize).copied().unwrap_or(NO_ORIGIN);
        for b in &mut self.bones {
            b.origin = get(b.module);
        }
        for i in &mut self.instances {
            i.origin = get(i.module);
        }
        for p in &mut self.polygons {
            p.origin = get(p.module);
        }
    }

    /// Append `other` moved by `offset` (a forest: one interpretation per
    /// tree, placed side by side). `other`'s module indices are shifted by
    /// `module_offset` (the length of the strings before its own, so that
    /// every part still names one module of the concatenated strings), its
    /// bone and polygon-vertex indices by what `self` already holds; the
    /// warnings add up. `None` (and `self` unchanged) when an index would
    /// no longer fit in 32 bits.
    pub fn append_translated(
        &mut self,
        other: &Interpretation,
        offset: Vec3,
        module_offset: u32,
    ) -> Option<()> {
        let bone_base = u32::try_from(self.bones.len()).ok()?;
        let vertex_base = u32::try_from(self.polygon_vertices.len()).ok()?;
        let fits = |base: u32, n: usize| u32::try_from(n).ok()?.checked_add(base);
        fits(bone_base, other.bones.len())?;
        fits(vertex_base, other.polygon_vertices.len())?;
        let module_end = [
            other.bones.iter().map(|b| b.module).max(),
            other.instances.iter().map(|i| i.module).max(),
            other.polygons.iter().map(|p| p.module).max(),
        ];
        if let Some(m) = module_end.into_iter().flatten().max() {
            m.checked_add(module_offset)?;
        }
        let module = |m: u32| m + module_offset;
        self.bones.extend(other.bones.iter().map(|b| Bone {
            base: b.base + offset,
            tip: b.tip + offset,
            parent: b.parent.map(|p| p + bone_base),
            module: module(b.module),
            ..*b
        }));
        let shift = Affine3A::from_translation(offset);
        self.instances
            .extend(other.instances.iter().map(|i| Instance {
                transform: shift * i.transform,
                bone: i.bone.map(|b| b + bone_base),
                module: module(i.module),
                ..*i
            }));
        self.polygons.extend(other.polygons.iter().map(|p| Polygon {
            first: p.first + vertex_base,
            module: module(p.module),
            ..*p
        }));
        self.polygon_vertices
            .extend(other.polygon_vertices.iter().map(|v| *v + offset));
        if !other.bounds.is_empty() {
            self.bounds = self.bounds.union(&Aabb {
                min: other.bounds.min + offset,
                max: other.bounds.max + offset,
            });
        }
        let (w, o) = (&mut self.warnings, &other.warnings);
        w.unbalanced_pops = w.unbalanced_pops.saturating_add(o.unbalanced_pops);
        w.unbalanced_polygon_ends = w
            .unbalanced_polygon_ends
            .saturating_add(o.unbalanced_polygon_ends);
        w.unclosed_polygons = w.unclosed_polygons.saturating_add(o.unclosed_polygons);
        w.degenerate_polygons = w.degenerate_polygons.saturating_add(o.degenerate_polygons);
        w.non_finite = w.non_finite.saturating_add(o.non_finite);
        w.bad_ids = w.bad_ids.saturating_add(o.bad_ids);
        Some(())
    }
}

/// Why a string could not be interpreted.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TurtleError {
    /// The string's arrays break the [`ModuleString`] invariant.
    MalformedString,
    /// Module `module` has a symbol id the system does not have.
    UnknownSymbol { module: usize, symbol: u32 },
    /// A range outside the string.
    BadRange {
        start: usize,
        end: usize,
        len: usize,
    },
}

impl std::fmt::Display for TurtleError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TurtleError::MalformedString => f.write_str("malformed module string"),
            TurtleError::UnknownSymbol { module, symbol } => write!(
                f,
                "module {module} has symbol id {symbol}, which the system does not define"
            ),
            TurtleError::BadRange { start, end, len } => write!(
                f,
                "module range {start}..{end} is outside the string of {len} modules"
            ),
        }
    }
}

impl std::error::Error for TurtleError {}

/// The settings the turtle reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TurtleConfig {
    /// Degrees, for commands without an argument.
    pub angle: f32,
    /// Length of `F f G g` without an argument.
    pub step: f32,
    /// Initial width.
    pub width: f32,
    /// World tropism vector T.
    pub tropism: Option<Vec3>,
    /// Susceptibility e.
    pub elasticity: f32,
}

impl TurtleConfig {
    pub fn from_settings(s: &Settings) -> TurtleConfig {
        let tropism = s
            .tropism
            .map(Vec3::from_array)
            .filter(|t| t.is_finite() && *t != Vec3::ZERO && s.elasticity != 0.0);
        TurtleConfig {
            angle: s.angle,
            step: s.step,
            width: s.width,
            tropism,
            elasticity: s.elasticity,
        }
    }
}

/// Receives what the turtle draws. [`Interpreter`] has one that builds an
/// [`Interpretation`]; the guided sampler may bring its own.
pub trait Sink {
    /// Record a bone; returns its index (the new current bone), or `None`
    /// when the sink dropped it (the current bone then stays).
    fn bone(&mut self, bone: Bone) -> Option<u32>;
    fn instance(&mut self, instance: Instance);
    /// `{`.
    fn polygon_start(&mut self);
    /// `.`, and `F`/`f` while a polygon is open (the sink decides).
    fn polygon_vertex(&mut self, p: Vec3);
    /// `}`.
    fn polygon_end(&mut self, paint: Paint, module: u32);
    /// A `mesh`/`material` argument that is not an id.
    fn bad_id(&mut self) {}
}

/// What the caller must do after a [`Turtle::step`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    Continue,
    /// `[`: save the state.
    Push,
    /// `]`: restore the saved state.
    Pop,
    /// `%`: skip to the `]` that closes the current branch.
    Cut,
}

/// The turtle state: what `[` saves and `]` restores. `Copy`, so the
/// sampler can keep one per open non-terminal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Turtle {
    /// Turtle space to world.
    pub frame: Affine3A,
    /// Current width (turtle units, a diameter).
    pub width: f32,
    pub paint: Paint,
    /// The last colour index set by `'`.
    pub color_index: u32,
    /// The current bone in this branch.
    pub bone: Option<u32>,
}

#[inline]
fn arg(params: &[f32], i: usize, default: f32) -> f32 {
    params.get(i).copied().unwrap_or(default)
}

#[inline]
fn arg3(params: &[f32], default: Vec3) -> Vec3 {
    match params {
        [x, y, z, ..] => Vec3::new(*x, *y, *z),
        _ => default,
    }
}

/// A parameter used as an id (mesh or material): a whole number >= 0.
#[inline]
fn as_id(x: f32) -> Option<u32> {
    (x.is_finite() && x >= 0.0 && x <= u32::MAX as f32 && x.fract() == 0.0).then_some(x as u32)
}

impl Turtle {
    /// The initial state: identity frame, the configured width, colour 0.
    pub fn new(cfg: &TurtleConfig) -> Turtle {
        Turtle {
            frame: Affine3A::IDENTITY,
            width: cfg.width,
            paint: Paint::Palette(0),
            color_index: 0,
            bone: None,
        }
    }

    pub fn position(&self) -> Vec3 {
        self.frame.translation.into()
    }

    /// H, unit length.
    pub fn heading(&self) -> Vec3 {
        Vec3::from(self.frame.matrix3.y_axis).normalize_or_zero()
    }

    /// L, unit length.
    pub fn left(&self) -> Vec3 {
        Vec3::from(self.frame.matrix3.x_axis).normalize_or_zero()
    }

    /// U, unit length.
    pub fn up(&self) -> Vec3 {
        -Vec3::from(self.frame.matrix3.z_axis).normalize_or_zero()
    }

    /// The frame's scale across the heading: mean length of the L and U columns.
    #[inline]
    pub fn lateral_scale(&self) -> f32 {
        0.5 * (self.frame.matrix3.x_axis.length() + self.frame.matrix3.z_axis.length())
    }

    #[inline]
    fn rotate_local(&mut self, r: Mat3A) {
        self.frame.matrix3 *= r;
    }

    #[inline]
    fn move_by(&mut self, len: f32) {
        self.frame.translation += self.frame.matrix3.y_axis * len;
    }

    fn tropism(&mut self, cfg: &TurtleConfig) {
        let Some(t) = cfg.tropism else { return };
        let h = self.frame.matrix3.y_axis.normalize_or_zero();
        let axis = h.cross(Vec3A::from(t));
        let s = axis.length();
        if s > 1e-9 && s.is_finite() {
            let r = Mat3A::from_axis_angle((axis / s).into(), cfg.elasticity * s);
            self.frame.matrix3 = r * self.frame.matrix3;
        }
    }

    /// `$`: roll about H so that L is horizontal (ABoP: L = V x H / |V x H|
    /// with V = +Y, U = H x L). Keeps the lengths of the frame's columns.
    fn roll_horizontal(&mut self) {
        let m = &mut self.frame.matrix3;
        let h = m.y_axis.normalize_or_zero();
        let l = Vec3A::Y.cross(h);
        let len = l.length();
        if len < 1e-6 || !len.is_finite() {
            return;
        }
        let l = l / len;
        let u = h.cross(l);
        let sx = m.x_axis.length();
        let sz = m.z_axis.length();
        m.x_axis = l * sx;
        m.z_axis = -u * sz;
    }

    fn instance<S: Sink>(&self, kind: InstanceKind, local: Affine3A, module: u32, sink: &mut S) {
        sink.instance(Instance {
            kind,
            transform: self.frame * local,
            paint: self.paint,
            bone: self.bone,
            module,
            origin: NO_ORIGIN,
        });
    }

    /// Interpret one terminal module with parameters `params` (index
    /// `module`). Missing parameters take the configured defaults.
    #[inline]
    pub fn step<S: Sink>(
        &mut self,
        terminal: Terminal,
        params: &[f32],
        module: u32,
        cfg: &TurtleConfig,
        sink: &mut S,
    ) -> Flow {
        use Terminal as T;
        let angle = || arg(params, 0, cfg.angle).to_radians();
        match terminal {
            T::Forward | T::ForwardNoVertex => {
                let base = self.position();
                self.move_by(arg(params, 0, cfg.step));
                let tip = self.position();
                let w = self.width * self.lateral_scale();
                let index = sink.bone(Bone {
                    base,
                    tip,
                    left: self.left(),
                    parent: self.bone,
                    width_base: w,
                    width_tip: w,
                    paint: self.paint,
                    module,
                    origin: NO_ORIGIN,
                });
                if index.is_some() {
                    self.bone = index;
                }
                self.tropism(cfg);
                if terminal == T::Forward {
                    sink.polygon_vertex(tip);
                }
            }
            T::Move => {
                self.move_by(arg(params, 0, cfg.step));
                sink.polygon_vertex(self.position());
            }
            T::MoveNoVertex => self.move_by(arg(params, 0, cfg.step)),
            T::TurnLeft => self.rotate_local(Mat3A::from_rotation_z(-angle())),
            T::TurnRight => self.rotate_local(Mat3A::from_rotation_z(angle())),
            T::PitchDown => self.rotate_local(Mat3A::from_rotation_x(angle())),
            T::PitchUp => self.rotate_local(Mat3A::from_rotation_x(-angle())),
            T::RollLeft => self.rotate_local(Mat3A::from_rotation_y(angle())),
            T::RollRight => self.rotate_local(Mat3A::from_rotation_y(-angle())),
            T::TurnAround => {
                // Exactly 180 degrees about local Z: negate X and Y.
                self.frame.matrix3.x_axis = -self.frame.matrix3.x_axis;
                self.frame.matrix3.y_axis = -self.frame.matrix3.y_axis;
            }
            T::RollHorizontal => self.roll_horizontal(),
            T::Push => return Flow::Push,
            T::Pop => return Flow::Pop,
            T::Cut => return Flow::Cut,
            T::SetWidth => {
                let w = arg(params, 0, cfg.width);
                if w.is_finite() {
                    self.width = w.max(0.0);
                }
            }
            T::ShrinkWidth => self.width *= SHRINK,
            T::SetColor => {
                let i = arg(params, 0, 0.0);
                self.color_index = if i.is_finite() && i > 0.0 {
                    i.min(u32::MAX as f32) as u32
                } else {
                    0
                };
                self.paint = Paint::Palette(self.color_index);
            }
            T::NextColor => {
                self.color_index = self.color_index.wrapping_add(1);
                self.paint = Paint::Palette(self.color_index);
            }
            T::PolygonStart => sink.polygon_start(),
            T::PolygonVertex => sink.polygon_vertex(self.position()),
            T::PolygonEnd => sink.polygon_end(self.paint, module),
            T::Translate => {
                let v = arg3(params, Vec3::ZERO);
                self.frame.translation += self.frame.matrix3 * Vec3A::from(v);
            }
            T::Rotate => {
                let axis = arg3(params, Vec3::Y);
                let a = arg(params, 3, cfg.angle).to_radians();
                let len = axis.length();
                if len > 1e-12 && len.is_finite() {
                    self.rotate_local(Mat3A::from_axis_angle(axis / len, a));
                }
            }
            T::RotX => self.rotate_local(Mat3A::from_rotation_x(angle())),
            T::RotY => self.rotate_local(Mat3A::from_rotation_y(angle())),
            T::RotZ => self.rotate_local(Mat3A::from_rotation_z(angle())),
            T::ScaleUniform => self.frame.matrix3 *= arg(params, 0, 1.0),
            T::Scale => {
                let s = arg3(params, Vec3::ONE);
                let m = &mut self.frame.matrix3;
                m.x_axis *= s.x;
                m.y_axis *= s.y;
                m.z_axis *= s.z;
            }
            T::Cylinder | T::Cone => {
                let r = arg(params, 0, 1.0);
                let h = arg(params, 1, 1.0);
                let kind = if terminal == T::Cylinder {
                    InstanceKind::Cylinder
                } else {
                    InstanceKind::Cone
                };
                let local = Affine3A::from_scale(Vec3::new(r, h, r));
                self.instance(kind, local, module, sink);
            }
            T::Sphere => {
                let local = Affine3A::from_scale(Vec3::splat(arg(params, 0, 1.0)));
                self.instance(InstanceKind::Sphere, local, module, sink);
            }
            T::Box => {
                let local = Affine3A::from_scale(arg3(params, Vec3::ONE));
                self.instance(InstanceKind::Box, local, module, sink);
            }
            T::Disc => {
                let r = arg(params, 0, 1.0);
                let local = Affine3A::from_scale(Vec3::new(r, 1.0, r));
                self.instance(InstanceKind::Disc, local, module, sink);
            }
            T::Mesh => match params.first().copied().and_then(as_id) {
                Some(id) => self.instance(
                    InstanceKind::Mesh(MeshId(id)),
                    Affine3A::IDENTITY,
                    module,
                    sink,
                ),
                None => sink.bad_id(),
            },
            T::Material => match params.first().copied().and_then(as_id) {
                Some(id) => self.paint = Paint::Material(MaterialId(id)),
                None => sink.bad_id(),
            },
            T::Color => {
                let c = arg3(params, Vec3::ONE);
                let c = if c.is_finite() {
                    c.clamp(Vec3::ZERO, Vec3::ONE)
                } else {
                    Vec3::ONE
                };
                self.paint = Paint::Rgb(c.to_array());
            }
        }
        Flow::Continue
    }
}

/// The corners of a unit shape's bounding box, for bounds.
fn unit_box(kind: InstanceKind) -> Option<(Vec3, Vec3)> {
    match kind {
        InstanceKind::Cylinder | InstanceKind::Cone => {
            Some((Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.0, 1.0)))
        }
        InstanceKind::Sphere => Some((Vec3::splat(-1.0), Vec3::splat(1.0))),
        InstanceKind::Box => Some((Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5))),
        InstanceKind::Disc => Some((Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0))),
        InstanceKind::Mesh(_) => None,
    }
}

/// The [`Sink`] that builds an [`Interpretation`].
#[derive(Debug, Default)]
pub struct Collector {
    pub out: Interpretation,
    /// Open polygons, innermost last; `open[..depth]` are live (the vectors
    /// past `depth` are kept for reuse).
    open: Vec<Vec<Vec3>>,
    depth: usize,
}

impl Collector {
    pub fn new() -> Collector {
        Collector::default()
    }

    /// Finish: drop open polygons (counted) and return the result.
    pub fn finish(mut self) -> Interpretation {
        self.out.warnings.unclosed_polygons += self.depth as u32;
        self.out
    }
}

impl Sink for Collector {
    #[inline]
    fn bone(&mut self, bone: Bone) -> Option<u32> {
        if !(bone.base.is_finite() && bone.tip.is_finite() && bone.width_tip.is_finite()) {
            self.out.warnings.non_finite += 1;
            return None;
        }
        self.out.bounds.add(bone.base);
        self.out.bounds.add(bone.tip);
        let index = self.out.bones.len() as u32;
        self.out.bones.push(bone);
        Some(index)
    }

    fn instance(&mut self, instance: Instance) {
        let t = instance.transform;
        let finite = t.matrix3.is_finite() && t.translation.is_finite();
        if !finite {
            self.out.warnings.non_finite += 1;
            return;
        }
        match unit_box(instance.kind) {
            Some((lo, hi)) => {
                for i in 0..8 {
                    let c = Vec3::new(
                        if i & 1 == 0 { lo.x } else { hi.x },
                        if i & 2 == 0 { lo.y } else { hi.y },
                        if i & 4 == 0 { lo.z } else { hi.z },
                    );
                    self.out.bounds.add(t.transform_point3(c));
                }
            }
            None => self.out.bounds.add(t.translation.into()),
        }
        self.out.instances.push(instance);
    }

    fn polygon_start(&mut self) {
        if self.open.len() <= self.depth {
            self.open.push(Vec::new());
        }
        self.open[self.depth].clear();
        self.depth += 1;
    }

    #[inline]
    fn polygon_vertex(&mut self, p: Vec3) {
        if self.depth == 0 {
            return;
        }
        if !p.is_finite() {
            self.out.warnings.non_finite += 1;
            return;
        }
        let poly = &mut self.open[self.depth - 1];
        if poly.last().is_none_or(|q| q.distance_squared(p) > 1e-12) {
            poly.push(p);
        }
    }

    fn polygon_end(&mut self, paint: Paint, module: u32) {
        if self.depth == 0 {
            self.out.warnings.unbalanced_polygon_ends += 1;
            return;
        }
        self.depth -= 1;
        let poly = &mut self.open[self.depth];
        // A closing vertex equal to the first is implied.
        if poly.len() > 1 && poly[0].distance_squared(poly[poly.len() - 1]) <= 1e-12 {
            poly.pop();
        }
        if poly.len() < 3 {
            self.out.warnings.degenerate_polygons += 1;
            return;
        }
        let first = self.out.polygon_vertices.len() as u32;
        for &p in poly.iter() {
            self.out.bounds.add(p);
        }
        self.out.polygon_vertices.extend_from_slice(poly);
        self.out.polygons.push(Polygon {
            first,
            len: poly.len() as u32,
            paint,
            module,
            origin: NO_ORIGIN,
        });
    }

    fn bad_id(&mut self) {
        self.out.warnings.bad_ids += 1;
    }
}

/// Interprets module strings of one system into a [`Collector`].
#[derive(Debug)]
pub struct Interpreter {
    /// Per symbol id: its terminal, or `None` for a user symbol.
    ops: Vec<Option<Terminal>>,
    cfg: TurtleConfig,
    stack: Vec<Turtle>,
    pub collector: Collector,
}

impl Interpreter {
    pub fn new(system: &System, settings: &Settings) -> Interpreter {
        let ops = system.terminals();
        Interpreter::from_parts(ops, TurtleConfig::from_settings(settings))
    }

    /// An interpreter over a symbol table given directly (index = symbol id).
    pub fn from_parts(ops: Vec<Option<Terminal>>, cfg: TurtleConfig) -> Interpreter {
        Interpreter {
            ops,
            cfg,
            stack: Vec::with_capacity(64),
            collector: Collector::new(),
        }
    }

    pub fn config(&self) -> &TurtleConfig {
        &self.cfg
    }

    /// The state at the start of a string.
    pub fn initial(&self) -> Turtle {
        Turtle::new(&self.cfg)
    }

    /// Interpret the whole string from the initial state.
    pub fn run(&mut self, string: &ModuleString) -> Result<Turtle, TurtleError> {
        let start = self.initial();
        self.run_range(start, string, 0..string.len(), &mut |_, _| {})
    }

    /// Interpret modules `range` of `string` starting from `start`; returns
    /// the final state. `on_user(i, state)` is called for each user module
    /// with the state it sits at (where its expansion starts, by frame
    /// locality). Brackets inside the range are balanced locally: a `]`
    /// without its `[` in the range is ignored (and counted), and `%` skips
    /// to the `]` closing its branch or to the end of the range.
    pub fn run_range(
        &mut self,
        start: Turtle,
        string: &ModuleString,
        range: Range<usize>,
        on_user: &mut dyn FnMut(usize, &Turtle),
    ) -> Result<Turtle, TurtleError> {
        if range.start > range.end || range.end > string.len() {
            return Err(TurtleError::BadRange {
                start: range.start,
                end: range.end,
                len: string.len(),
            });
        }
        // Only the range is read: checking it alone keeps a caller that
        // interprets a growing string piece by piece (the sampler's
        // geometry phase) linear, not quadratic, in the string's length.
        if !string.is_well_formed_in(range.clone()) {
            return Err(TurtleError::MalformedString);
        }
        let base_depth = self.stack.len();
        let mut t = start;
        let mut i = range.start;
        while i < range.end {
            // Well-formedness of the range (checked above) makes this
            // slice valid.
            let (sym, p) = string.get(i);
            let op = match self.ops.get(sym as usize) {
                Some(op) => *op,
                None => {
                    self.stack.truncate(base_depth);
                    return Err(TurtleError::UnknownSymbol {
                        module: i,
                        symbol: sym,
                    });
                }
            };
            match op {
                None => on_user(i, &t),
                Some(term) => match t.step(term, p, i as u32, &self.cfg, &mut self.collector) {
                    Flow::Continue => {}
                    Flow::Push => self.stack.push(t),
                    Flow::Pop => {
                        if self.stack.len() > base_depth {
                            // Just checked non-empty.
                            t = self.stack.pop().unwrap_or(t);
                        } else {
                            self.collector.out.warnings.unbalanced_pops += 1;
                        }
                    }
                    Flow::Cut => {
                        i = self.skip_branch(string, i + 1, range.end);
                        continue;
                    }
                },
            }
            i += 1;
        }
        self.stack.truncate(base_depth);
        Ok(t)
    }

    /// The index of the `]` closing the branch that `from` is in, or `end`.
    fn skip_branch(&self, string: &ModuleString, from: usize, end: usize) -> usize {
        let mut depth = 0u32;
        for j in from..end {
            match self.ops.get(string.sym(j) as usize) {
                Some(Some(Terminal::Push)) => depth += 1,
                Some(Some(Terminal::Pop)) => {
                    if depth == 0 {
                        return j;
                    }
                    depth -= 1;
                }
                _ => {}
            }
        }
        end
    }

    /// The interpretation so far.
    pub fn output(&self) -> &Interpretation {
        &self.collector.out
    }

    pub fn finish(self) -> Interpretation {
        self.collector.finish()
    }
}

/// Interpret a whole string of `system` from the initial state.
pub fn interpret(
    system: &System,
    settings: &Settings,
    string: &ModuleString,
) -> Result<Interpretation, TurtleError> {
    let mut it = Interpreter::new(system, settings);
    it.run(string)?;
    Ok(it.finish())
}

//! The words of shape mode (docs/language.md section 8, docs/shapes.md):
//! axes, roof kinds, component-split targets and selectors, context
//! queries and primitives, each with its name as written and the list of
//! them all.
//!
//! Defined once, here: the checker reads grammars with them, the shape
//! engine (`grm_shape`, which re-exports them) runs them, and the editor
//! analysis (`grm-analysis`) lists their names for hover and completion.

/// A context query's relation: how the asking shape's box relates to the
/// boxes of the first pass's shapes of a symbol (docs/shapes.md, "Context
/// queries"). The shape engine calls it `grm_shape::Query`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShapeQuery {
    /// The boxes share volume (or area, for flat boxes).
    Overlaps,
    /// The boxes meet, but only on their boundaries.
    Touches,
    /// The asking box lies inside one box.
    Inside,
}

impl ShapeQuery {
    pub const ALL: &'static [ShapeQuery] = &[
        ShapeQuery::Overlaps,
        ShapeQuery::Touches,
        ShapeQuery::Inside,
    ];

    /// `overlaps`, `touches` or `inside`.
    pub fn name(self) -> &'static str {
        match self {
            ShapeQuery::Overlaps => "overlaps",
            ShapeQuery::Touches => "touches",
            ShapeQuery::Inside => "inside",
        }
    }

    pub fn from_name(s: &str) -> Option<ShapeQuery> {
        ShapeQuery::ALL.iter().copied().find(|k| k.name() == s)
    }

    /// Every name, in the order of [`ShapeQuery::ALL`].
    pub fn names() -> impl Iterator<Item = &'static str> + Clone {
        ShapeQuery::ALL.iter().map(|k| k.name())
    }
}

/// A scope axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub const ALL: &'static [Axis] = &[Axis::X, Axis::Y, Axis::Z];

    /// 0, 1 or 2.
    #[inline]
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// `x`, `y` or `z`.
    pub fn name(self) -> &'static str {
        ["x", "y", "z"][self.index()]
    }

    pub fn from_name(s: &str) -> Option<Axis> {
        Axis::ALL.iter().copied().find(|k| k.name() == s)
    }

    /// Every name, in the order of [`Axis::ALL`].
    pub fn names() -> impl Iterator<Item = &'static str> + Clone {
        Axis::ALL.iter().map(|k| k.name())
    }
}

/// The axes `center(...)` takes, as written: one, two or all three of
/// `x`, `y`, `z`, in that order.
pub const CENTER_AXES: &[&str] = &["x", "y", "z", "xy", "xz", "yz", "xyz"];

/// What kind of roof.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RoofKind {
    /// A flat top face over the footprint (an overhang widens it).
    Flat,
    /// A hip roof whose wing ends are vertical gables.
    Gable,
    /// Every edge slopes at the angle (the straight skeleton roof).
    Hip,
    /// One plane rising from the front edge (outward normal most along -y);
    /// the other edges are vertical.
    Shed,
    /// Every edge slopes to one apex over the centroid.
    Pyramid,
}

impl RoofKind {
    pub const ALL: &'static [RoofKind] = &[
        RoofKind::Flat,
        RoofKind::Gable,
        RoofKind::Hip,
        RoofKind::Shed,
        RoofKind::Pyramid,
    ];

    /// `flat`, `gable`, `hip`, `shed` or `pyramid`.
    pub fn name(self) -> &'static str {
        match self {
            RoofKind::Flat => "flat",
            RoofKind::Gable => "gable",
            RoofKind::Hip => "hip",
            RoofKind::Shed => "shed",
            RoofKind::Pyramid => "pyramid",
        }
    }

    pub fn from_name(s: &str) -> Option<RoofKind> {
        RoofKind::ALL.iter().copied().find(|k| k.name() == s)
    }

    /// Every name, in the order of [`RoofKind::ALL`].
    pub fn names() -> impl Iterator<Item = &'static str> + Clone {
        RoofKind::ALL.iter().map(|k| k.name())
    }
}

/// What a component split breaks a shape into.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CompTarget {
    /// The faces of a mass (its walls, top and bottom).
    Faces,
    /// The edges of a mass or of a face.
    Edges,
}

impl CompTarget {
    pub const ALL: &'static [CompTarget] = &[CompTarget::Faces, CompTarget::Edges];

    /// `faces` or `edges`.
    pub fn name(self) -> &'static str {
        match self {
            CompTarget::Faces => "faces",
            CompTarget::Edges => "edges",
        }
    }

    pub fn from_name(s: &str) -> Option<CompTarget> {
        CompTarget::ALL.iter().copied().find(|k| k.name() == s)
    }

    /// Every name, in the order of [`CompTarget::ALL`].
    pub fn names() -> impl Iterator<Item = &'static str> + Clone {
        CompTarget::ALL.iter().map(|k| k.name())
    }
}

/// Which components a case of a component split takes, by orientation
/// (docs/shapes.md, "Component split"). A component goes to the first case
/// whose selector matches it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Selector {
    /// Facing the scope's -y (walls), or, for edges of a face, -x... see [`Selector::name`].
    Front,
    Back,
    Left,
    Right,
    /// Every vertical wall (front, back, left, right); the vertical edges of a mass.
    Side,
    Top,
    Bottom,
    /// Everything.
    All,
    /// A roof's sloped faces (and a taper's leaning walls).
    Slope,
    /// A roof's vertical gable ends (and a shed's vertical walls).
    Gable,
    /// A roof's horizontal edges at its eaves under a slope.
    Eave,
    /// A roof's horizontal edges above its eaves.
    Ridge,
    /// A roof's inclined edges where two slopes meet in a convex corner.
    Hip,
    /// A roof's inclined edges where two slopes meet in a concave corner.
    Valley,
    /// A roof's inclined edges between a slope and a gable end.
    Rake,
}

impl Selector {
    pub const ALL: &'static [Selector] = &[
        Selector::Front,
        Selector::Back,
        Selector::Left,
        Selector::Right,
        Selector::Side,
        Selector::Top,
        Selector::Bottom,
        Selector::All,
        Selector::Slope,
        Selector::Gable,
        Selector::Eave,
        Selector::Ridge,
        Selector::Hip,
        Selector::Valley,
        Selector::Rake,
    ];

    /// The selector's name as written in a grammar.
    pub fn name(self) -> &'static str {
        match self {
            Selector::Front => "front",
            Selector::Back => "back",
            Selector::Left => "left",
            Selector::Right => "right",
            Selector::Side => "side",
            Selector::Top => "top",
            Selector::Bottom => "bottom",
            Selector::All => "all",
            Selector::Slope => "slope",
            Selector::Gable => "gable",
            Selector::Eave => "eave",
            Selector::Ridge => "ridge",
            Selector::Hip => "hip",
            Selector::Valley => "valley",
            Selector::Rake => "rake",
        }
    }

    pub fn from_name(s: &str) -> Option<Selector> {
        Selector::ALL.iter().copied().find(|k| k.name() == s)
    }

    /// Every name, in the order of [`Selector::ALL`].
    pub fn names() -> impl Iterator<Item = &'static str> + Clone {
        Selector::ALL.iter().map(|k| k.name())
    }
}

/// A primitive `insert` places.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Primitive {
    Box,
    Cylinder,
    Cone,
    Sphere,
    Disc,
}

impl Primitive {
    pub const ALL: &'static [Primitive] = &[
        Primitive::Box,
        Primitive::Cylinder,
        Primitive::Cone,
        Primitive::Sphere,
        Primitive::Disc,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Primitive::Box => "box",
            Primitive::Cylinder => "cylinder",
            Primitive::Cone => "cone",
            Primitive::Sphere => "sphere",
            Primitive::Disc => "disc",
        }
    }

    pub fn from_name(s: &str) -> Option<Primitive> {
        Primitive::ALL.iter().copied().find(|k| k.name() == s)
    }

    /// Every name, in the order of [`Primitive::ALL`].
    pub fn names() -> impl Iterator<Item = &'static str> + Clone {
        Primitive::ALL.iter().map(|k| k.name())
    }
}

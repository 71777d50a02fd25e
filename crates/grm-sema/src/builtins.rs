//! The built-in vocabulary: functions, random draws, turtle and geometry
//! terminals, settings and material properties, with their signatures.

use crate::program::{Settings, Ty, Value};

/// A parameter type in a built-in signature: fixed, or the generic `T`
/// shared by all `Gen` positions of one call.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PTy {
    F,
    V,
    /// Generic: `float` or `vec3` (or any type for `choose` and `if`).
    Gen,
}

macro_rules! builtins {
    ($( $variant:ident = $name:literal ($($arg:ident),*) -> $ret:ident; )*) => {
        /// A pure built-in function.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Builtin {
            $( $variant, )*
        }

        impl Builtin {
            pub const ALL: &'static [Builtin] = &[ $( Builtin::$variant, )* ];

            pub fn name(self) -> &'static str {
                match self { $( Builtin::$variant => $name, )* }
            }

            pub fn from_name(s: &str) -> Option<Builtin> {
                match s { $( $name => Some(Builtin::$variant), )* _ => None }
            }

            pub(crate) fn signature(self) -> (&'static [PTy], PTy) {
                match self { $( Builtin::$variant => (&[$(PTy::$arg),*], PTy::$ret), )* }
            }
        }
    };
}

builtins! {
    Sin = "sin"(F) -> F;
    Cos = "cos"(F) -> F;
    Tan = "tan"(F) -> F;
    Asin = "asin"(F) -> F;
    Acos = "acos"(F) -> F;
    Atan = "atan"(F) -> F;
    Atan2 = "atan2"(F, F) -> F;
    Sqrt = "sqrt"(F) -> F;
    Exp = "exp"(F) -> F;
    Ln = "ln"(F) -> F;
    Log10 = "log10"(F) -> F;
    Pow = "pow"(F, F) -> F;
    Abs = "abs"(Gen) -> Gen;
    Floor = "floor"(Gen) -> Gen;
    Ceil = "ceil"(Gen) -> Gen;
    Round = "round"(Gen) -> Gen;
    Fract = "fract"(Gen) -> Gen;
    Sign = "sign"(Gen) -> Gen;
    Min = "min"(Gen, Gen) -> Gen;
    Max = "max"(Gen, Gen) -> Gen;
    Clamp = "clamp"(Gen, Gen, Gen) -> Gen;
    Mix = "mix"(Gen, Gen, F) -> Gen;
    Step = "step"(Gen, Gen) -> Gen;
    Smoothstep = "smoothstep"(Gen, Gen, Gen) -> Gen;
    Vec3 = "vec3"(F, F, F) -> V;
    Rgb = "rgb"(F, F, F) -> V;
    Dot = "dot"(V, V) -> F;
    Cross = "cross"(V, V) -> V;
    Length = "length"(V) -> F;
    Normalize = "normalize"(V) -> V;
    Distance = "distance"(V, V) -> F;
    // `spline(t, c0, c1, ..., cn)`: variadic, see `Builtin::arity_ok`.
    Spline = "spline"(F, Gen) -> Gen;
}

impl Builtin {
    /// Whether `n` arguments are accepted, and a description of the
    /// accepted counts for error messages.
    pub(crate) fn arity(self) -> (fn(usize) -> bool, &'static str) {
        match self {
            Builtin::Spline => (|n| n >= 5, "at least 5 (t and 4 or more control values)"),
            _ => match self.signature().0.len() {
                1 => (|n| n == 1, "1"),
                2 => (|n| n == 2, "2"),
                _ => (|n| n == 3, "3"),
            },
        }
    }

    /// The parameter type of argument `i` (for variadic `spline`, every
    /// argument after `t` is generic).
    pub(crate) fn param(self, i: usize) -> PTy {
        let (ps, _) = self.signature();
        ps.get(i).copied().unwrap_or(PTy::Gen)
    }
}

/// A random draw. Draws are deterministic per (seed, stage, position, draw index).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RandomFn {
    /// `uniform(a, b)`: float in [a, b).
    Uniform,
    /// `normal(mean, sd)`.
    Normal,
    /// `randint(a, b)`: whole number in [a, b].
    RandInt,
    /// `choose(v0, w0, v1, w1, ...)`: vi with probability wi / sum w.
    Choose,
    /// `chance(p)`: true with probability p.
    Chance,
}

impl RandomFn {
    pub const ALL: &'static [RandomFn] = &[
        RandomFn::Uniform,
        RandomFn::Normal,
        RandomFn::RandInt,
        RandomFn::Choose,
        RandomFn::Chance,
    ];

    pub fn name(self) -> &'static str {
        match self {
            RandomFn::Uniform => "uniform",
            RandomFn::Normal => "normal",
            RandomFn::RandInt => "randint",
            RandomFn::Choose => "choose",
            RandomFn::Chance => "chance",
        }
    }

    pub fn from_name(s: &str) -> Option<RandomFn> {
        RandomFn::ALL.iter().copied().find(|f| f.name() == s)
    }
}

/// All function names (built-ins and random draws), for suggestions.
pub(crate) fn function_names() -> impl Iterator<Item = &'static str> {
    Builtin::ALL
        .iter()
        .map(|b| b.name())
        .chain(RandomFn::ALL.iter().map(|r| r.name()))
}

/// A built-in terminal: turtle command, transform or geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Terminal {
    /// `F(l)`: move and draw a bone.
    Forward,
    /// `f(l)`: move without drawing.
    Move,
    /// `G(l)`: as `F`, recording no polygon vertex.
    ForwardNoVertex,
    /// `g(l)`: as `f`, recording no polygon vertex.
    MoveNoVertex,
    /// `+(a)`: turn left about U.
    TurnLeft,
    /// `-(a)`: turn right about U.
    TurnRight,
    /// `&(a)`: pitch down about L.
    PitchDown,
    /// `^(a)`: pitch up about L.
    PitchUp,
    /// `\(a)`: roll left about H.
    RollLeft,
    /// `/(a)`: roll right about H.
    RollRight,
    /// `|`: turn 180 degrees about U.
    TurnAround,
    /// `$`: roll so that L is horizontal.
    RollHorizontal,
    /// `[` / `push`.
    Push,
    /// `]` / `pop`.
    Pop,
    /// `!(w)`: set the width.
    SetWidth,
    /// `!`: multiply the width by 0.7.
    ShrinkWidth,
    /// `'(i)`: set the colour index.
    SetColor,
    /// `'`: next colour index.
    NextColor,
    /// `{`: start a polygon.
    PolygonStart,
    /// `.`: record a polygon vertex.
    PolygonVertex,
    /// `}`: close the polygon.
    PolygonEnd,
    /// `%`: erase the rest of the branch.
    Cut,
    /// `translate(v)` / `translate(x, y, z)`: one vec3 parameter.
    Translate,
    /// `rotate(axis, a)`.
    Rotate,
    /// `rotx(a)`.
    RotX,
    /// `roty(a)`.
    RotY,
    /// `rotz(a)`.
    RotZ,
    /// `scale(s)`: uniform.
    ScaleUniform,
    /// `scale(x, y, z)`: one vec3 parameter.
    Scale,
    /// `cylinder(r, h)`.
    Cylinder,
    /// `cone(r, h)`.
    Cone,
    /// `sphere(r)`.
    Sphere,
    /// `box(x, y, z)`.
    Box,
    /// `disc(r)`.
    Disc,
    /// `mesh(name)`.
    Mesh,
    /// `material(name)`.
    Material,
    /// `color(r, g, b)` / `color(v)`: one vec3 parameter.
    Color,
}

impl Terminal {
    /// Every terminal, in declaration order.
    pub const ALL: &'static [Terminal] = &[
        Terminal::Forward,
        Terminal::Move,
        Terminal::ForwardNoVertex,
        Terminal::MoveNoVertex,
        Terminal::TurnLeft,
        Terminal::TurnRight,
        Terminal::PitchDown,
        Terminal::PitchUp,
        Terminal::RollLeft,
        Terminal::RollRight,
        Terminal::TurnAround,
        Terminal::RollHorizontal,
        Terminal::Push,
        Terminal::Pop,
        Terminal::SetWidth,
        Terminal::ShrinkWidth,
        Terminal::SetColor,
        Terminal::NextColor,
        Terminal::PolygonStart,
        Terminal::PolygonVertex,
        Terminal::PolygonEnd,
        Terminal::Cut,
        Terminal::Translate,
        Terminal::Rotate,
        Terminal::RotX,
        Terminal::RotY,
        Terminal::RotZ,
        Terminal::ScaleUniform,
        Terminal::Scale,
        Terminal::Cylinder,
        Terminal::Cone,
        Terminal::Sphere,
        Terminal::Box,
        Terminal::Disc,
        Terminal::Mesh,
        Terminal::Material,
        Terminal::Color,
    ];

    /// Canonical spelling.
    pub fn name(self) -> &'static str {
        use Terminal::*;
        match self {
            Forward => "F",
            Move => "f",
            ForwardNoVertex => "G",
            MoveNoVertex => "g",
            TurnLeft => "+",
            TurnRight => "-",
            PitchDown => "&",
            PitchUp => "^",
            RollLeft => "\\",
            RollRight => "/",
            TurnAround => "|",
            RollHorizontal => "$",
            Push => "[",
            Pop => "]",
            SetWidth | ShrinkWidth => "!",
            SetColor | NextColor => "'",
            PolygonStart => "{",
            PolygonVertex => ".",
            PolygonEnd => "}",
            Cut => "%",
            Translate => "translate",
            Rotate => "rotate",
            RotX => "rotx",
            RotY => "roty",
            RotZ => "rotz",
            ScaleUniform | Scale => "scale",
            Cylinder => "cylinder",
            Cone => "cone",
            Sphere => "sphere",
            Box => "box",
            Disc => "disc",
            Mesh => "mesh",
            Material => "material",
            Color => "color",
        }
    }

    /// The parameter types every module of this terminal carries.
    pub fn params(self) -> &'static [Ty] {
        use Terminal::*;
        match self {
            Forward | Move | ForwardNoVertex | MoveNoVertex | TurnLeft | TurnRight | PitchDown
            | PitchUp | RollLeft | RollRight | SetWidth | SetColor | RotX | RotY | RotZ
            | ScaleUniform | Sphere | Disc => &[Ty::Float],
            TurnAround | RollHorizontal | Push | Pop | ShrinkWidth | NextColor | PolygonStart
            | PolygonVertex | PolygonEnd | Cut => &[],
            Translate | Scale | Color => &[Ty::Vec3],
            Rotate => &[Ty::Vec3, Ty::Float],
            Cylinder | Cone => &[Ty::Float, Ty::Float],
            Box => &[Ty::Float, Ty::Float, Ty::Float],
            Mesh => &[Ty::Mesh],
            Material => &[Ty::Material],
        }
    }

    /// Geometry terminals: in sample systems only geometry symbols may emit them.
    pub fn is_geometry(self) -> bool {
        use Terminal::*;
        matches!(
            self,
            Cylinder | Cone | Sphere | Box | Disc | Mesh | Material | Color
        )
    }

    /// Bracket terminals.
    pub fn is_bracket(self) -> bool {
        matches!(self, Terminal::Push | Terminal::Pop)
    }
}

/// How a written form of a terminal becomes its canonical parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Fill {
    /// Arguments as written.
    AsIs,
    /// No argument written: use the system's `step`.
    Step,
    /// No argument written: use the system's `angle`.
    Angle,
    /// Three floats packed into one `vec3(x, y, z)`.
    Pack3,
}

/// One written form of a built-in terminal: `name` with `n` arguments.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Form {
    pub terminal: Terminal,
    /// Argument types as written.
    pub written: &'static [Ty],
    pub fill: Fill,
}

const F1: &[Ty] = &[Ty::Float];
const F2: &[Ty] = &[Ty::Float, Ty::Float];
const F3: &[Ty] = &[Ty::Float, Ty::Float, Ty::Float];
const NONE: &[Ty] = &[];

/// The written forms of a built-in terminal name, or `None` for a user symbol.
pub(crate) fn terminal_forms(name: &str) -> Option<&'static [Form]> {
    use Fill::*;
    use Terminal::*;
    macro_rules! forms {
        ($($t:expr, $w:expr, $f:expr);* $(;)?) => {{
            const FORMS: &[Form] = &[$(Form { terminal: $t, written: $w, fill: $f }),*];
            FORMS
        }};
    }
    Some(match name {
        "F" => forms![Forward, NONE, Step; Forward, F1, AsIs],
        "f" => forms![Move, NONE, Step; Move, F1, AsIs],
        "G" => forms![ForwardNoVertex, NONE, Step; ForwardNoVertex, F1, AsIs],
        "g" => forms![MoveNoVertex, NONE, Step; MoveNoVertex, F1, AsIs],
        "+" => forms![TurnLeft, NONE, Angle; TurnLeft, F1, AsIs],
        "-" => forms![TurnRight, NONE, Angle; TurnRight, F1, AsIs],
        "&" => forms![PitchDown, NONE, Angle; PitchDown, F1, AsIs],
        "^" => forms![PitchUp, NONE, Angle; PitchUp, F1, AsIs],
        "\\" => forms![RollLeft, NONE, Angle; RollLeft, F1, AsIs],
        "/" => forms![RollRight, NONE, Angle; RollRight, F1, AsIs],
        "|" => forms![TurnAround, NONE, AsIs],
        "$" => forms![RollHorizontal, NONE, AsIs],
        "[" | "push" => forms![Push, NONE, AsIs],
        "]" | "pop" => forms![Pop, NONE, AsIs],
        "!" => forms![ShrinkWidth, NONE, AsIs; SetWidth, F1, AsIs],
        "'" => forms![NextColor, NONE, AsIs; SetColor, F1, AsIs],
        "{" => forms![PolygonStart, NONE, AsIs],
        "." => forms![PolygonVertex, NONE, AsIs],
        "}" => forms![PolygonEnd, NONE, AsIs],
        "%" => forms![Cut, NONE, AsIs],
        "translate" => forms![Translate, &[Ty::Vec3], AsIs; Translate, F3, Pack3],
        "rotate" => forms![Rotate, &[Ty::Vec3, Ty::Float], AsIs],
        "rotx" => forms![RotX, NONE, Angle; RotX, F1, AsIs],
        "roty" => forms![RotY, NONE, Angle; RotY, F1, AsIs],
        "rotz" => forms![RotZ, NONE, Angle; RotZ, F1, AsIs],
        "scale" => forms![ScaleUniform, F1, AsIs; Scale, F3, Pack3],
        "cylinder" => forms![Cylinder, F2, AsIs],
        "cone" => forms![Cone, F2, AsIs],
        "sphere" => forms![Sphere, F1, AsIs],
        "box" => forms![Box, F3, AsIs],
        "disc" => forms![Disc, F1, AsIs],
        "mesh" => forms![Mesh, &[Ty::Mesh], AsIs],
        "material" => forms![Material, &[Ty::Material], AsIs],
        "color" => forms![Color, &[Ty::Vec3], AsIs; Color, F3, Pack3],
        _ => return None,
    })
}

/// Human list of accepted argument counts, e.g. "0 or 1".
pub(crate) fn form_counts(forms: &[Form]) -> String {
    let mut ns: Vec<usize> = forms.iter().map(|f| f.written.len()).collect();
    ns.dedup();
    match ns.as_slice() {
        [a] => format!("{a}"),
        [a, b] => format!("{a} or {b}"),
        _ => ns
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// A system setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SettingKey {
    Mode,
    Iterations,
    Angle,
    Seed,
    Step,
    Width,
    Tropism,
    Elasticity,
    Generations,
    ParticlesStart,
    ParticlesEnd,
}

/// The most iterations a system derives: far past any string that grows
/// (those reach the module limits within a few dozen), and a bound on what
/// a string that does not grow can spend.
pub const MAX_ITERATIONS: u32 = 100_000;
/// The most generations of a guided search.
pub const MAX_GENERATIONS: u32 = 100_000;
/// The most particles of a guided search (each holds a derivation).
pub const MAX_PARTICLES: u32 = 100_000;

impl SettingKey {
    pub const ALL: &'static [SettingKey] = &[
        SettingKey::Mode,
        SettingKey::Iterations,
        SettingKey::Angle,
        SettingKey::Seed,
        SettingKey::Step,
        SettingKey::Width,
        SettingKey::Tropism,
        SettingKey::Elasticity,
        SettingKey::Generations,
        SettingKey::ParticlesStart,
        SettingKey::ParticlesEnd,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SettingKey::Mode => "mode",
            SettingKey::Iterations => "iterations",
            SettingKey::Angle => "angle",
            SettingKey::Seed => "seed",
            SettingKey::Step => "step",
            SettingKey::Width => "width",
            SettingKey::Tropism => "tropism",
            SettingKey::Elasticity => "elasticity",
            SettingKey::Generations => "generations",
            SettingKey::ParticlesStart => "particles_start",
            SettingKey::ParticlesEnd => "particles_end",
        }
    }

    pub fn from_name(s: &str) -> Option<SettingKey> {
        SettingKey::ALL.iter().copied().find(|k| k.name() == s)
    }

    /// The value type (`mode` takes a name, not a value).
    pub fn ty(self) -> Ty {
        match self {
            SettingKey::Tropism => Ty::Vec3,
            _ => Ty::Float,
        }
    }

    /// Settings that only sample systems use.
    pub fn sample_only(self) -> bool {
        matches!(
            self,
            SettingKey::Generations | SettingKey::ParticlesStart | SettingKey::ParticlesEnd
        )
    }

    /// The largest value a whole-number setting takes: what a derivation,
    /// a search or an allocation sized by it can do (`seed` takes any
    /// 32-bit value). `grmc`'s flags and the preview's overrides are held
    /// to the same bounds.
    pub fn max_whole(self) -> u32 {
        match self {
            SettingKey::Iterations => MAX_ITERATIONS,
            SettingKey::Generations => MAX_GENERATIONS,
            SettingKey::ParticlesStart | SettingKey::ParticlesEnd => MAX_PARTICLES,
            _ => u32::MAX,
        }
    }

    /// Validate a value and store it. The error says what is allowed.
    pub fn apply(self, s: &mut Settings, v: Value) -> Result<(), String> {
        fn whole(key: SettingKey, v: Value, min: f64) -> Result<u32, String> {
            let x = v.as_float().unwrap_or(f64::NAN);
            let max = key.max_whole();
            if x.is_finite() && x.fract() == 0.0 && x >= min && x <= f64::from(max) {
                Ok(x as u32)
            } else if x > f64::from(max) {
                Err(format!("`{}` must be at most {max}, found {v}", key.name(),))
            } else {
                Err(format!(
                    "`{}` must be a whole number >= {min}, found {v}",
                    key.name()
                ))
            }
        }
        fn finite(key: SettingKey, v: Value, min: Option<f64>) -> Result<f32, String> {
            let x = v.as_float().unwrap_or(f64::NAN);
            // The engines read the setting as the 32-bit float nearest to
            // it: a value that rounds to f32::MAX (3.4028235e38, as f32
            // prints it) is finite there, one that rounds to infinity not.
            let ok = fits_f32(x) && min.is_none_or(|m| x >= m);
            if ok {
                Ok(x as f32)
            } else if let Some(m) = min {
                Err(format!(
                    "`{}` must be a finite number >= {m}, found {v}",
                    key.name()
                ))
            } else {
                Err(format!(
                    "`{}` must be a finite number, found {v}",
                    key.name()
                ))
            }
        }
        /// Whether `x` is a finite number whose nearest 32-bit float is finite.
        fn fits_f32(x: f64) -> bool {
            (x as f32).is_finite()
        }
        match self {
            SettingKey::Mode => {}
            SettingKey::Iterations => s.iterations = whole(self, v, 0.0)?,
            SettingKey::Seed => s.seed = whole(self, v, 0.0)?,
            SettingKey::Generations => s.generations = whole(self, v, 1.0)?,
            SettingKey::ParticlesStart => s.particles_start = whole(self, v, 1.0)?,
            SettingKey::ParticlesEnd => s.particles_end = whole(self, v, 1.0)?,
            SettingKey::Angle => s.angle = finite(self, v, None)?,
            SettingKey::Step => s.step = finite(self, v, None)?,
            SettingKey::Width => s.width = finite(self, v, Some(0.0))?,
            SettingKey::Elasticity => s.elasticity = finite(self, v, None)?,
            SettingKey::Tropism => {
                let t = v.as_vec3().unwrap_or([f64::NAN; 3]);
                if t.iter().all(|&x| fits_f32(x)) {
                    s.tropism = Some([t[0] as f32, t[1] as f32, t[2] as f32]);
                } else {
                    return Err(format!("`tropism` must be a finite vector, found {v}"));
                }
            }
        }
        Ok(())
    }
}

/// A material property.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MaterialProp {
    /// Base colour (vec3, linear RGB in [0, 1]).
    Color,
    /// Roughness in [0, 1].
    Roughness,
    /// Metalness in [0, 1].
    Metallic,
    /// Emitted colour (vec3).
    Emissive,
    /// Opacity in [0, 1].
    Opacity,
}

impl MaterialProp {
    pub const ALL: &'static [MaterialProp] = &[
        MaterialProp::Color,
        MaterialProp::Roughness,
        MaterialProp::Metallic,
        MaterialProp::Emissive,
        MaterialProp::Opacity,
    ];

    pub fn name(self) -> &'static str {
        match self {
            MaterialProp::Color => "color",
            MaterialProp::Roughness => "roughness",
            MaterialProp::Metallic => "metallic",
            MaterialProp::Emissive => "emissive",
            MaterialProp::Opacity => "opacity",
        }
    }

    pub fn from_name(s: &str) -> Option<MaterialProp> {
        MaterialProp::ALL.iter().copied().find(|p| p.name() == s)
    }

    pub fn ty(self) -> Ty {
        match self {
            MaterialProp::Color | MaterialProp::Emissive => Ty::Vec3,
            _ => Ty::Float,
        }
    }
}

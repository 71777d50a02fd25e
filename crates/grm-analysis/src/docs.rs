//! The documentation table: one entry for every keyword, built-in function,
//! random draw, turtle / transform / geometry terminal, system setting,
//! material property and type name of the language (docs/language.md is
//! the source of the wording). Hover, completion and signature help read
//! it; a test checks it against the checker's own lists.

/// What a documented name is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DocKind {
    Keyword,
    /// A pure built-in function (`sin`, `vec3`, ...).
    Function,
    /// A random draw (`uniform`, `chance`, ...).
    Random,
    /// A turtle, transform or geometry terminal (`F`, `+`, `cylinder`, ...).
    Terminal,
    /// A system setting (`iterations = 5;`).
    Setting,
    /// A material property (`roughness = 0.9;`).
    MaterialProp,
    /// A type name (`float`, `vec3`, `bool`).
    Type,
    /// A value of the `mode` setting (`derive`, `sample`, `shape`).
    ModeValue,
    /// An operation of a shape system's rule (`extrude`, `split`, ...).
    ShapeOp,
    /// An axis argument of a shape operation (`x`, `y`, `z`, `xy`, ...).
    Axis,
    /// What a component split breaks a shape into (`faces`, `edges`).
    CompKind,
    /// A component split's case selector (`front`, `side`, `slope`, ...).
    Selector,
    /// A roof's kind (`flat`, `gable`, `hip`, `shed`, `pyramid`).
    RoofKind,
    /// A primitive `insert` places (`box`, `cylinder`, ...).
    Primitive,
    /// A value of the shape being rewritten (`scope`, `index`, `tagged`, ...).
    ShapeValue,
    /// A lot's shape (`lot = rect(24, 10);`).
    Lot,
    /// How a part's size is written (`~` floating, `%` relative).
    PartSize,
    /// A semantic tag in common use (`floor`, `column`, `facade`).
    Tag,
}

impl DocKind {
    pub fn describe(self) -> &'static str {
        match self {
            DocKind::Keyword => "keyword",
            DocKind::Function => "built-in function",
            DocKind::Random => "random draw",
            DocKind::Terminal => "turtle command",
            DocKind::Setting => "system setting",
            DocKind::MaterialProp => "material property",
            DocKind::Type => "type",
            DocKind::ModeValue => "system mode",
            DocKind::ShapeOp => "shape operation",
            DocKind::Axis => "axis",
            DocKind::CompKind => "component kind",
            DocKind::Selector => "component selector",
            DocKind::RoofKind => "roof kind",
            DocKind::Primitive => "primitive",
            DocKind::ShapeValue => "shape value",
            DocKind::Lot => "lot",
            DocKind::PartSize => "part size",
            DocKind::Tag => "semantic tag",
        }
    }
}

/// One documented name.
#[derive(Clone, Copy, Debug)]
pub struct DocEntry {
    pub name: &'static str,
    pub kind: DocKind,
    /// Written forms, e.g. `uniform(a: float, b: float) -> float` or
    /// `F` and `F(l: float)`. Empty for keywords.
    pub signatures: &'static [&'static str],
    pub doc: &'static str,
}

impl DocEntry {
    /// Markdown for hover and completion.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        if !self.signatures.is_empty() {
            s.push_str("```grm\n");
            for sig in self.signatures {
                s.push_str(sig);
                s.push('\n');
            }
            s.push_str("```\n");
        }
        s.push_str(&format!("*{}*: {}", self.kind.describe(), self.doc));
        s
    }
}

/// The parameters of a signature label `name(a: float, b) -> float`, as
/// byte ranges into the label (for signature help).
pub fn signature_params(label: &str) -> Vec<(usize, usize)> {
    let Some(open) = label.find('(') else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut depth = 0i32;
    let mut start = open + 1;
    for (i, c) in label.char_indices().skip_while(|&(i, _)| i <= open) {
        match c {
            '(' => depth += 1,
            ')' if depth == 0 => {
                if i > start {
                    out.push((start, i));
                }
                return out;
            }
            ')' => depth -= 1,
            ',' if depth == 0 => {
                out.push((start, i));
                start = i + 2; // ", "
            }
            _ => {}
        }
    }
    out
}

macro_rules! entries {
    ($( $kind:ident $name:literal [$($sig:literal),*] $doc:literal; )*) => {
        /// Every documented name.
        pub const ENTRIES: &[DocEntry] = &[
            $( DocEntry { name: $name, kind: DocKind::$kind, signatures: &[$($sig),*], doc: $doc }, )*
        ];
    };
}

entries! {
    // ---- keywords ----------------------------------------------------------
    Keyword "import" [] "`import \"file.grm\";` brings the constants, parameters, meshes, materials and systems of another file into scope (path relative to this file).";
    Keyword "const" [] "`const NAME [: type] = expr;` a named constant expression (may use other constants and parameters, not random draws).";
    Keyword "param" [] "`param NAME = default in lo .. hi;` a meta-parameter: a slider in the preview, overridable with `grmc --param NAME=value`.";
    Keyword "mesh" [] "`mesh NAME = \"file.obj\";` declares an OBJ mesh (path relative to this file); emit it with `mesh(NAME)`.";
    Keyword "material" [] "`material NAME { color = rgb(..); roughness = ..; }` declares a material; apply it with `material(NAME)`.";
    Keyword "system" [] "`system NAME { ... }` a grammar: settings, an axiom and productions. The first system of a file is the default one.";
    Keyword "module" [] "`module A(len: float, w: float), B;` declares module symbols and their parameter types (otherwise inferred from use).";
    Keyword "skeleton" [] "`skeleton A, B;` (sample systems) declares skeleton symbols: expanded during the guided search and scored against the curves; each needs a `wrapup` production.";
    Keyword "geometry" [] "`geometry leaf;` (sample systems) declares geometry symbols: expanded to completion after the search; may not emit skeleton symbols.";
    Keyword "wrapup" [] "`wrapup A -> ...;` (sample systems) closes an open skeleton symbol when the search ends; its successor contains no skeleton symbols.";
    Keyword "axiom" [] "`axiom MODULES;` the start string of a system.";
    Keyword "ignore" [] "`ignore + - F;` symbols skipped while matching contexts.";
    Keyword "in" [] "`param p = 30 in 10 .. 60;` introduces a meta-parameter's range.";
    Keyword "if" [] "`if c then a else b`: a conditional expression.";
    Keyword "then" [] "`if c then a else b`: the value when `c` is true.";
    Keyword "else" [] "`if c then a else b`: the value when `c` is false.";
    Keyword "true" [] "the boolean constant true.";
    Keyword "false" [] "the boolean constant false.";
    ModeValue "derive" [] "`mode = derive;` (the default): parallel L-system rewriting for `iterations` steps.";
    ModeValue "sample" [] "`mode = sample;`: the guided sampler (SOSMC) grows the skeleton against guiding curves, then wrap-up and the geometry phase.";
    ModeValue "shape" [] "`mode = shape;`: a split grammar for buildings: rules rewrite shapes (a symbol, a scope and geometry) from the lot by extruding, splitting, repeating and breaking masses into faces (docs/shapes.md).";

    // ---- types ------------------------------------------------------------
    Type "float" [] "a 32-bit floating-point number (constants are folded in 64 bits).";
    Type "vec3" [] "a 3-component vector (`vec3(x, y, z)`, fields `.x .y .z`); colours are vec3 too.";
    Type "bool" [] "`true` or `false`; conditions are bool.";

    // ---- math -------------------------------------------------------------
    Function "sin" ["sin(a: float) -> float"] "sine of an angle in degrees.";
    Function "cos" ["cos(a: float) -> float"] "cosine of an angle in degrees.";
    Function "tan" ["tan(a: float) -> float"] "tangent of an angle in degrees.";
    Function "asin" ["asin(x: float) -> float"] "arc sine, in degrees.";
    Function "acos" ["acos(x: float) -> float"] "arc cosine, in degrees.";
    Function "atan" ["atan(x: float) -> float"] "arc tangent, in degrees.";
    Function "atan2" ["atan2(y: float, x: float) -> float"] "the angle of the point (x, y), in degrees.";
    Function "sqrt" ["sqrt(x: float) -> float"] "square root.";
    Function "exp" ["exp(x: float) -> float"] "e raised to x.";
    Function "ln" ["ln(x: float) -> float"] "natural logarithm.";
    Function "log10" ["log10(x: float) -> float"] "base-10 logarithm.";
    Function "pow" ["pow(x: float, y: float) -> float"] "x raised to y.";
    Function "abs" ["abs(x: T) -> T"] "absolute value (component-wise on vec3).";
    Function "floor" ["floor(x: T) -> T"] "largest whole number <= x (component-wise on vec3).";
    Function "ceil" ["ceil(x: T) -> T"] "smallest whole number >= x (component-wise on vec3).";
    Function "round" ["round(x: T) -> T"] "nearest whole number (component-wise on vec3).";
    Function "fract" ["fract(x: T) -> T"] "fractional part `x - floor(x)` (component-wise on vec3).";
    Function "sign" ["sign(x: T) -> T"] "-1, 0 or 1 (component-wise on vec3).";
    Function "min" ["min(a: T, b: T) -> T"] "the smaller value (component-wise on vec3).";
    Function "max" ["max(a: T, b: T) -> T"] "the larger value (component-wise on vec3).";
    Function "clamp" ["clamp(x: T, lo: T, hi: T) -> T"] "x limited to [lo, hi].";
    Function "mix" ["mix(a: T, b: T, t: float) -> T"] "linear interpolation `a + (b - a) * t`.";
    Function "step" ["step(edge: T, x: T) -> T"] "0 when x < edge, else 1.";
    Function "smoothstep" ["smoothstep(lo: T, hi: T, x: T) -> T"] "smooth Hermite step from 0 at lo to 1 at hi.";
    // ---- vectors ----------------------------------------------------------
    Function "vec3" ["vec3(x: float, y: float, z: float) -> vec3"] "builds a vector.";
    Function "rgb" ["rgb(r: float, g: float, b: float) -> vec3"] "a colour (linear RGB in [0, 1]); a colour is a vec3.";
    Function "dot" ["dot(a: vec3, b: vec3) -> float"] "dot product.";
    Function "cross" ["cross(a: vec3, b: vec3) -> vec3"] "cross product.";
    Function "length" ["length(v: vec3) -> float"] "Euclidean length.";
    Function "normalize" ["normalize(v: vec3) -> vec3"] "the unit vector along v.";
    Function "distance" ["distance(a: vec3, b: vec3) -> float"] "Euclidean distance between two points.";
    Function "spline" ["spline(t: float, c0: T, c1: T, c2: T, c3: T, ...) -> T"] "uniform cubic B-spline through n+1 >= 4 control values, t in [0, 1].";
    // ---- random -----------------------------------------------------------
    Random "uniform" ["uniform(a: float, b: float) -> float"] "a uniform draw in [a, b). Draws are deterministic: a hash of (seed, iteration, position, draw index).";
    Random "normal" ["normal(mean: float, sd: float) -> float"] "a normally distributed draw.";
    Random "randint" ["randint(a: float, b: float) -> float"] "a whole number in [a, b].";
    Random "choose" ["choose(v0: T, w0: float, v1: T, w1: float, ...) -> T"] "value vi with probability wi / sum of the weights.";
    Random "chance" ["chance(p: float) -> bool"] "true with probability p.";

    // ---- turtle terminals -------------------------------------------------
    Terminal "F" ["F", "F(l: float)"] "move forward l (default: the system's `step`) and draw a segment: a bone from the position before to the position after, parented to the current bone.";
    Terminal "f" ["f", "f(l: float)"] "move forward l (default `step`) without drawing.";
    Terminal "G" ["G", "G(l: float)"] "as `F`, but no vertex is recorded in an open polygon.";
    Terminal "g" ["g", "g(l: float)"] "as `f`, but no vertex is recorded in an open polygon.";
    Terminal "+" ["+", "+(a: float)"] "turn left by a degrees (default `angle`) about the up vector U.";
    Terminal "-" ["-", "-(a: float)"] "turn right by a degrees (default `angle`) about the up vector U.";
    Terminal "&" ["&", "&(a: float)"] "pitch down by a degrees (default `angle`) about the left vector L.";
    Terminal "^" ["^", "^(a: float)"] "pitch up by a degrees (default `angle`) about the left vector L.";
    Terminal "\\" ["\\", "\\(a: float)"] "roll left by a degrees (default `angle`) about the heading H.";
    Terminal "/" ["/", "/(a: float)"] "roll right by a degrees (default `angle`) about the heading H (write two rolls as `/ /`: `//` starts a comment).";
    Terminal "|" ["|"] "turn around: 180 degrees about U.";
    Terminal "$" ["$"] "roll so that the left vector L is horizontal.";
    Terminal "[" ["["] "push the turtle state (start a branch); also written `push`.";
    Terminal "]" ["]"] "pop the turtle state (end a branch); also written `pop`.";
    Terminal "push" ["push"] "same as `[`: push the turtle state.";
    Terminal "pop" ["pop"] "same as `]`: pop the turtle state.";
    Terminal "!" ["!", "!(w: float)"] "set the width to w; without an argument multiply the width by 0.7.";
    Terminal "'" ["'", "'(i: float)"] "set the colour index to i; without an argument go to the next colour.";
    Terminal "{" ["{"] "start a polygon.";
    Terminal "." ["."] "record a polygon vertex.";
    Terminal "}" ["}"] "close the polygon.";
    Terminal "%" ["%"] "cut: erase the rest of the current branch.";
    Terminal "translate" ["translate(v: vec3)", "translate(x: float, y: float, z: float)"] "move without drawing.";
    Terminal "rotate" ["rotate(axis: vec3, a: float)"] "rotate a degrees about an axis in turtle space.";
    Terminal "rotx" ["rotx", "rotx(a: float)"] "rotate a degrees (default `angle`) about the turtle's x axis.";
    Terminal "roty" ["roty", "roty(a: float)"] "rotate a degrees (default `angle`) about the turtle's y axis.";
    Terminal "rotz" ["rotz", "rotz(a: float)"] "rotate a degrees (default `angle`) about the turtle's z axis.";
    Terminal "scale" ["scale(s: float)", "scale(x: float, y: float, z: float)"] "scale the turtle frame, uniformly or per axis.";
    // ---- geometry terminals -----------------------------------------------
    Terminal "cylinder" ["cylinder(r: float, h: float)"] "a cylinder of radius r and height h along the heading. In sample systems only geometry symbols may emit it.";
    Terminal "cone" ["cone(r: float, h: float)"] "a cone of base radius r and height h along the heading.";
    Terminal "sphere" ["sphere(r: float)"] "a sphere of radius r.";
    Terminal "box" ["box(x: float, y: float, z: float)"] "a box with these side lengths.";
    Terminal "disc" ["disc(r: float)"] "a disc of radius r facing the heading.";
    Terminal "color" ["color(c: vec3)", "color(r: float, g: float, b: float)"] "set the colour of the geometry that follows.";

    // ---- settings ---------------------------------------------------------
    Setting "mode" ["mode = derive | sample | shape"] "how the system is run: `derive` (default, parallel rewriting), `sample` (guided search) or `shape` (a split grammar for buildings).";
    Setting "iterations" ["iterations = n"] "number of rewriting steps (whole number, default 1).";
    Setting "angle" ["angle = degrees"] "default angle of `+ - & ^ \\ /` and `rotx roty rotz` (default 90).";
    Setting "seed" ["seed = n"] "default random seed (whole number, default 0).";
    Setting "step" ["step = length"] "default length of `F f G g` (default 1).";
    Setting "width" ["width = w"] "initial width for `!` and tubes (default 0.1).";
    Setting "tropism" ["tropism = vec3(x, y, z)"] "tropism vector T bending the turtle (unset by default).";
    Setting "elasticity" ["elasticity = e"] "tropism susceptibility e (default 0).";
    Setting "generations" ["generations = n"] "sample systems: SOSMC generations (default 100).";
    Setting "particles_start" ["particles_start = n"] "sample systems: particles at the first generation (default 100).";
    Setting "particles_end" ["particles_end = n"] "sample systems: particles at the last generation (default 15).";
    Setting "lot" ["lot = rect(w, d)", "lot = polygon(x0, y0, x1, y1, ...)", "lot = \"block.geojson\""] "shape systems: the axiom's footprint, in the xy plane (default `rect(10, 10)`); a GeoJSON file's holes are courtyards.";

    // ---- shape systems (mode = shape) -------------------------------------
    Lot "rect" ["rect(w: float, d: float)"] "a `w` by `d` rectangle, its corner at the origin.";
    Lot "polygon" ["polygon(x0: float, y0: float, x1: float, y1: float, ...)"] "a simple polygon of three or more corners, in either winding.";
    ShapeOp "extrude" ["extrude(h: float)"] "a footprint or face becomes a mass `h` high (along the scope's z).";
    ShapeOp "taper" ["taper(h: float)"] "a footprint becomes a solid whose walls lean in to meet `h` above it.";
    ShapeOp "roof" ["roof(kind, angle: float)", "roof(kind, angle: float, overhang: float)"] "a roof on the footprint or on a mass's top: `kind` is `flat`, `gable`, `hip`, `shed` or `pyramid`, `angle` the pitch in degrees; its faces are the components `slope` and `gable`, its edges `eave`, `ridge` and `hip`.";
    ShapeOp "translate" ["translate(x: float, y: float, z: float)"] "moves the scope along its own axes.";
    ShapeOp "rotate" ["rotate(axis, degrees: float)"] "turns the scope about its `x`, `y` or `z` axis.";
    ShapeOp "size" ["size(x: float, y: float, z: float)"] "sets the scope's size; `_` keeps an axis.";
    ShapeOp "center" ["center(axes)"] "centres the scope on `x`, `y`, `z`, `xy`, `xz`, `yz` or `xyz` in the scope saved by `[`.";
    ShapeOp "[" ["["] "saves the scope and geometry (and the attributes).";
    ShapeOp "]" ["]"] "restores the scope and geometry saved by the matching `[`.";
    ShapeOp "offset" ["offset(d: float)"] "offsets the outline by `d` (negative: inset).";
    ShapeOp "insert" ["insert(name)"] "places a primitive (`box`, `cylinder`, `cone`, `sphere`, `disc`) or a declared `mesh`, fitted to the scope.";
    ShapeOp "material" ["material(name: material)"] "draws the shape and everything it makes with a declared material.";
    ShapeOp "color" ["color(c: vec3)"] "draws the shape and everything it makes with a linear RGB colour.";
    ShapeOp "texture" ["texture(file: string)"] "maps an image on the shape's faces by their UV coordinates.";
    ShapeOp "split" ["split(axis) { size: Symbol | ... }", "split(axis, tag) { size: Symbol | ... }"] "divides the scope along `x`, `y` or `z` into parts: `4: A` is 4 units long, `25%: A` a quarter of the scope, `~1: A` floating (floating parts share what the others leave). A tag names the parts in the semantic locator.";
    ShapeOp "repeat" ["repeat(axis) { size: Symbol | ... }", "repeat(axis, tag) { size: Symbol | ... }"] "lays the parts as one tile as many times as fit along `x`, `y` or `z` (`~w` means about `w`: the tiles stretch to fill the scope). A tag names the tiles in the semantic locator.";
    ShapeOp "comp" ["comp(faces) { selector: Symbol | ... }", "comp(faces, tag) { selector: Symbol | ... }", "comp(edges) { selector: Symbol | ... }"] "breaks a mass, face or roof into faces or edges; each goes to the first case whose selector takes it, named by the selector and its index within the case. A tag names the components in the semantic locator.";
    ShapeOp "nil" ["nil"] "makes nothing there (a part or case that leaves a gap).";
    Axis "x" ["x"] "the scope's x axis (along a facade: its width).";
    Axis "y" ["y"] "the scope's y axis (on a facade: up; on a footprint or mass: its depth).";
    Axis "z" ["z"] "the scope's z axis (on a mass: up; on a facade: its outward normal).";
    Axis "xy" ["xy"] "the scope's x and y axes.";
    Axis "xz" ["xz"] "the scope's x and z axes.";
    Axis "yz" ["yz"] "the scope's y and z axes.";
    Axis "xyz" ["xyz"] "all three axes of the scope.";
    Axis "_" ["_"] "keeps the scope's size on this axis.";
    CompKind "faces" ["faces"] "the faces of a mass (a wall per straight run of the footprint, then the top, then the bottom), of a roof (its slopes and gable ends), or a face itself.";
    CompKind "edges" ["edges"] "the edges of a mass (ground, roof and vertical edges), of a face (its outline) or of a roof (eaves, ridges, hips).";
    Selector "front" ["front"] "the walls (or edges) facing -y.";
    Selector "back" ["back"] "the walls (or edges) facing +y.";
    Selector "left" ["left"] "the walls (or edges) facing -x.";
    Selector "right" ["right"] "the walls (or edges) facing +x.";
    Selector "side" ["side"] "every wall (of a mass's edges, the vertical ones; of a face's, left or right).";
    Selector "top" ["top"] "the horizontal face (or edges) on top.";
    Selector "bottom" ["bottom"] "the horizontal face (or edges) at the bottom.";
    Selector "all" ["all"] "every component.";
    Selector "slope" ["slope"] "a roof's sloped faces.";
    Selector "gable" ["gable"] "a roof's vertical gable ends.";
    Selector "eave" ["eave"] "a roof's lower horizontal edges.";
    Selector "ridge" ["ridge"] "a roof's upper horizontal edges.";
    Selector "hip" ["hip"] "a roof's sloped edges where two slopes meet.";
    Selector "valley" ["valley"] "a roof's sloped edges where two slopes meet in a hollow (an inner corner of the footprint).";
    Selector "rake" ["rake"] "a gable roof's sloped edges along its gable ends.";
    RoofKind "flat" ["flat"] "a flat roof (with its overhang).";
    RoofKind "gable" ["gable"] "two slopes meeting at a ridge, with vertical gable ends.";
    RoofKind "hip" ["hip"] "slopes on every side, on the footprint's straight skeleton.";
    RoofKind "shed" ["shed"] "one slope over the whole footprint.";
    RoofKind "pyramid" ["pyramid"] "slopes on every side meeting at one apex.";
    Primitive "box" ["box"] "a box filling the scope.";
    Primitive "cylinder" ["cylinder"] "a cylinder fitted to the scope (along its z).";
    Primitive "cone" ["cone"] "a cone fitted to the scope (along its z).";
    Primitive "sphere" ["sphere"] "a sphere (ellipsoid) fitted to the scope.";
    Primitive "disc" ["disc"] "a disc in the scope's xy.";
    ShapeValue "scope" ["scope: vec3"] "the shape's scope size (`scope.x`, `scope.y`, `scope.z`).";
    ShapeValue "index" ["index: float"] "which part, tile or component the shape is, from 1.";
    ShapeValue "count" ["count: float"] "how many parts, tiles or components its command made.";
    ShapeValue "depth" ["depth: float"] "the shape's depth in the tree (the axiom is 0).";
    ShapeValue "tagged" ["tagged(tag) -> bool"] "whether a command with this tag is above the shape.";
    ShapeValue "overlaps" ["overlaps(Symbol) -> bool"] "whether the shape's box overlaps a shape of that symbol (a context query, evaluated in a second pass: the answer never depends on order or thread count).";
    ShapeValue "touches" ["touches(Symbol) -> bool"] "whether the shape's box touches a shape of that symbol (a context query).";
    ShapeValue "inside" ["inside(Symbol) -> bool"] "whether the shape's box lies inside a shape of that symbol (a context query).";
    PartSize "~" ["~w: Symbol"] "a floating part: the floating parts share what the fixed parts leave, in proportion to their weights (in a repeat, `~w` means about `w`).";
    PartSize "%" ["p%: Symbol"] "a relative part: `p` percent of the scope along the axis.";
    Tag "floor" ["floor"] "the floors of a facade or mass: the parts of a split or repeat along the vertical axis.";
    Tag "column" ["column"] "the columns of a facade: the parts of a split or repeat along its x axis.";
    Tag "facade" ["facade"] "the faces of a mass's component split.";

    // ---- material properties ----------------------------------------------
    MaterialProp "roughness" ["roughness = r"] "roughness in [0, 1].";
    MaterialProp "metallic" ["metallic = m"] "metalness in [0, 1].";
    MaterialProp "emissive" ["emissive = rgb(r, g, b)"] "emitted colour (vec3).";
    MaterialProp "opacity" ["opacity = a"] "opacity in [0, 1].";
}

/// Names with two meanings are told apart by the kind asked for:
/// `mesh` / `material` (keyword and terminal) and `color` (terminal and
/// material property).
const SPECIAL: &[DocEntry] = &[
    DocEntry {
        name: "mesh",
        kind: DocKind::Terminal,
        signatures: &["mesh(name: mesh)"],
        doc: "emit a declared mesh (`mesh leaf = \"leaf.obj\";`) at the turtle.",
    },
    DocEntry {
        name: "material",
        kind: DocKind::Terminal,
        signatures: &["material(name: material)"],
        doc: "apply a declared material to the geometry that follows.",
    },
    DocEntry {
        name: "color",
        kind: DocKind::MaterialProp,
        signatures: &["color = rgb(r, g, b)"],
        doc: "base colour (vec3, linear RGB in [0, 1]).",
    },
];

/// The entry for a name of a given kind.
pub fn lookup(name: &str, kind: DocKind) -> Option<&'static DocEntry> {
    ENTRIES
        .iter()
        .chain(SPECIAL)
        .find(|e| e.name == name && e.kind == kind)
}

/// The entries of one kind (for completion).
pub fn of_kind(kind: DocKind) -> impl Iterator<Item = &'static DocEntry> {
    ENTRIES
        .iter()
        .chain(SPECIAL)
        .filter(move |e| e.kind == kind)
}

/// A function or random draw by name.
pub fn function(name: &str) -> Option<&'static DocEntry> {
    lookup(name, DocKind::Function).or_else(|| lookup(name, DocKind::Random))
}

/// Whether `name` is a reserved word.
pub fn is_keyword(name: &str) -> bool {
    lookup(name, DocKind::Keyword).is_some()
}

#[cfg(test)]
mod tests {
    use super::*;
    use grm_sema::{Builtin, MaterialProp, RandomFn, SettingKey, Terminal};

    /// Exhaustive: a new terminal variant fails to compile here until it is
    /// documented.
    fn terminal_name(t: Terminal) -> &'static str {
        use Terminal::*;
        match t {
            Forward | Move | ForwardNoVertex | MoveNoVertex | TurnLeft | TurnRight | PitchDown
            | PitchUp | RollLeft | RollRight | TurnAround | RollHorizontal | Push | Pop
            | SetWidth | ShrinkWidth | SetColor | NextColor | PolygonStart | PolygonVertex
            | PolygonEnd | Cut | Translate | Rotate | RotX | RotY | RotZ | ScaleUniform | Scale
            | Cylinder | Cone | Sphere | Box | Disc | Mesh | Material | Color => t.name(),
        }
    }

    #[test]
    fn every_builtin_is_documented() {
        for b in Builtin::ALL {
            assert!(
                lookup(b.name(), DocKind::Function).is_some(),
                "{}",
                b.name()
            );
        }
        for r in RandomFn::ALL {
            assert!(lookup(r.name(), DocKind::Random).is_some(), "{}", r.name());
        }
        for k in SettingKey::ALL {
            assert!(lookup(k.name(), DocKind::Setting).is_some(), "{}", k.name());
        }
        for p in MaterialProp::ALL {
            assert!(
                lookup(p.name(), DocKind::MaterialProp).is_some(),
                "{}",
                p.name()
            );
        }
        for name in grm_syntax::PUNCT_SYMBOLS {
            assert!(lookup(name, DocKind::Terminal).is_some(), "{name}");
        }
        for &t in Terminal::ALL {
            let n = terminal_name(t);
            assert!(lookup(n, DocKind::Terminal).is_some(), "{n}");
        }
        // The reserved words of docs/language.md.
        for kw in "import const param mesh material system module skeleton geometry wrapup axiom ignore in if then else true false".split(' ') {
            assert!(is_keyword(kw), "{kw}");
        }
    }

    #[test]
    fn every_shape_word_is_documented() {
        use grm_sema::shape::{
            Axis, CENTER_AXES, CompTarget, Primitive, RoofKind, Selector, ShapeQuery,
        };
        let words = [
            (
                DocKind::Axis,
                Axis::names().chain(CENTER_AXES.iter().copied()).collect(),
            ),
            (DocKind::CompKind, CompTarget::names().collect()),
            (DocKind::Selector, Selector::names().collect()),
            (DocKind::RoofKind, RoofKind::names().collect()),
            (DocKind::Primitive, Primitive::names().collect()),
            (DocKind::ShapeValue, ShapeQuery::names().collect::<Vec<_>>()),
        ];
        for (kind, names) in words {
            for n in names {
                assert!(lookup(n, kind).is_some(), "{n}");
            }
        }
        for m in [
            grm_sema::Mode::Derive,
            grm_sema::Mode::Sample,
            grm_sema::Mode::Shape,
        ] {
            assert!(
                lookup(m.name(), DocKind::ModeValue).is_some(),
                "{}",
                m.name()
            );
        }
        // The operations of docs/language.md section 8.
        for op in "extrude taper roof translate rotate size center [ ] offset insert material color texture split repeat comp".split(' ') {
            assert!(lookup(op, DocKind::ShapeOp).is_some(), "{op}");
        }
    }

    #[test]
    fn documented_terminals_are_terminals() {
        // Every word terminal in the table is one the checker knows: used
        // in a successor it resolves to a terminal, never a user symbol.
        for e in of_kind(DocKind::Terminal) {
            if !e.name.chars().next().is_some_and(char::is_alphabetic) {
                continue;
            }
            let sig = e.signatures[0];
            let args = signature_params(sig).len();
            let call = if args == 0 {
                e.name.to_string()
            } else {
                let a = vec!["1"; args].join(", ");
                format!("{}({a})", e.name)
            };
            let text = format!(
                "mesh m = \"m.obj\";\nmaterial mat {{ roughness = 1; }}\nsystem S {{ axiom A; A -> {call}; }}"
            );
            let mut loader = grm_sema::MemLoader::new();
            loader.add_binary("m.obj");
            let (_, checked) = grm_sema::check_with("t.grm", &text, &loader);
            let sys = &checked.program.systems[0];
            assert!(
                sys.symbols
                    .iter()
                    .any(|s| s.is_terminal() && s.name == e.name
                        || (e.name == "push" && s.name == "[")
                        || (e.name == "pop" && s.name == "]")),
                "{}",
                e.name
            );
        }
    }

    #[test]
    fn signature_parameters() {
        let l = "mix(a: T, b: T, t: float) -> T";
        let ps: Vec<&str> = signature_params(l).iter().map(|&(a, b)| &l[a..b]).collect();
        assert_eq!(ps, ["a: T", "b: T", "t: float"]);
        assert!(signature_params("F").is_empty());
    }
}

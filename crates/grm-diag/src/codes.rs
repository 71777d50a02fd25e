//! The one list of diagnostic codes. Each code is stable: once released it is
//! never reused for a different problem. `docs/diagnostics.md` lists every
//! code with an example, and a test checks that the two lists agree.

use crate::Severity;

macro_rules! codes {
    ($( $(#[$m:meta])* $variant:ident = $code:literal, $sev:ident, $title:literal; )*) => {
        /// A stable diagnostic code.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Code {
            $( $(#[$m])* $variant, )*
        }

        impl Code {
            /// Every code, in documentation order.
            pub const ALL: &'static [Code] = &[ $( Code::$variant, )* ];

            /// The code as written in output, e.g. `E0101`.
            pub fn as_str(self) -> &'static str {
                match self { $( Code::$variant => $code, )* }
            }

            /// The severity a diagnostic with this code has.
            pub fn severity(self) -> Severity {
                match self { $( Code::$variant => Severity::$sev, )* }
            }

            /// A short title for the code (used in docs and `--explain`).
            pub fn title(self) -> &'static str {
                match self { $( Code::$variant => $title, )* }
            }

            /// Look a code up by its written form.
            pub fn from_str_code(s: &str) -> Option<Code> {
                match s { $( $code => Some(Code::$variant), )* _ => None }
            }
        }
    };
}

codes! {
    // ---- E00xx: lexing and parsing -------------------------------------
    /// A token the grammar does not allow here.
    UnexpectedToken = "E0001", Error, "unexpected token";
    /// The file ended in the middle of a construct.
    UnexpectedEof = "E0002", Error, "unexpected end of file";
    /// A character that starts no token.
    InvalidCharacter = "E0003", Error, "invalid character";
    /// A string literal without its closing quote.
    UnterminatedString = "E0004", Error, "unterminated string";
    /// A block comment without its closing `*/`.
    UnterminatedComment = "E0005", Error, "unterminated block comment";
    /// A number literal that cannot be represented.
    InvalidNumber = "E0006", Error, "invalid number literal";
    /// A top-level declaration (`param`, `const`, `mesh`, `material`,
    /// `import`) written inside a system block.
    DeclInsideSystem = "E0007", Error, "declaration inside a system";

    // ---- E01xx: names ----------------------------------------------------
    /// A name that refers to nothing in scope.
    UnknownName = "E0101", Error, "unknown name";
    /// Two definitions of the same name in one scope.
    DuplicateDefinition = "E0102", Error, "duplicate definition";
    /// A function name that is not a built-in.
    UnknownFunction = "E0103", Error, "unknown function";
    /// A type name that is not `float`, `vec3` or `bool`.
    UnknownType = "E0104", Error, "unknown type";
    /// A system setting that does not exist.
    UnknownSetting = "E0105", Error, "unknown setting";
    /// A setting given twice in one system.
    DuplicateSetting = "E0106", Error, "duplicate setting";
    /// A field of a vector that does not exist (only `x`, `y`, `z`).
    UnknownField = "E0107", Error, "unknown field";
    /// A material property that does not exist.
    UnknownMaterialProperty = "E0108", Error, "unknown material property";
    /// A pattern binds the same parameter name twice.
    DuplicateParameter = "E0109", Error, "duplicate parameter";

    // ---- E02xx: types ----------------------------------------------------
    /// An expression whose type is not the one required.
    TypeMismatch = "E0201", Error, "type mismatch";
    /// A module used with a different number of parameters than elsewhere.
    ModuleArity = "E0202", Error, "module arity mismatch";
    /// A built-in function called with the wrong number of arguments.
    FunctionArity = "E0203", Error, "wrong number of arguments";
    /// A production condition that is not boolean.
    ConditionNotBool = "E0204", Error, "condition is not boolean";
    /// An expression that must be constant but depends on module parameters or random draws.
    NotConstant = "E0205", Error, "expression is not constant";
    /// Division or remainder by an expression that is constantly zero.
    DivisionByZero = "E0206", Error, "division by constant zero";
    /// A production weight that is constantly zero or negative.
    NonPositiveWeight = "E0207", Error, "weight is not positive";
    /// A setting whose value is out of its allowed range.
    InvalidSettingValue = "E0208", Error, "invalid setting value";
    /// A meta-parameter whose range is empty or excludes its default.
    InvalidParamRange = "E0209", Error, "invalid parameter range";
    /// A recursive definition of constants.
    CyclicConstant = "E0210", Error, "cyclic constant definition";
    /// An expression nested deeper than the checker follows (a guard against
    /// pathological input; real grammars stay far below it).
    ExprTooDeep = "E0211", Error, "expression nested too deeply";
    /// A material property or `color(...)` value that is not a finite number.
    InvalidUnitValue = "E0212", Error, "colour or material value is not a number";

    // ---- E03xx: systems, phases, guided mode ----------------------------
    /// A skeleton symbol's production emits a geometry terminal directly.
    SkeletonEmitsGeometry = "E0301", Error, "skeleton symbol emits geometry";
    /// A wrap-up production for a symbol that is not a skeleton symbol.
    WrapupNotSkeleton = "E0302", Error, "wrap-up of a non-skeleton symbol";
    /// A wrap-up production whose successor still contains a skeleton symbol.
    WrapupLeavesSkeleton = "E0303", Error, "wrap-up leaves a skeleton symbol open";
    /// A non-terminal of a sample system with no declared phase.
    MissingPhase = "E0304", Error, "symbol has no phase";
    /// Context-sensitive production in a system whose mode cannot honour it.
    ContextInSampleMode = "E0305", Error, "context not supported in sample mode";
    /// A skeleton symbol with no wrap-up production.
    MissingWrapup = "E0306", Error, "skeleton symbol has no wrap-up";
    /// A symbol none of whose productions can ever finish.
    NonTerminating = "E0307", Error, "symbol can never terminate";
    /// A geometry symbol's production emits a skeleton symbol.
    GeometryEmitsSkeleton = "E0308", Error, "geometry symbol emits a skeleton symbol";
    /// A wrap-up production in a derive system.
    WrapupInDerive = "E0309", Error, "wrap-up in a derive system";
    /// A system without an axiom.
    MissingAxiom = "E0310", Error, "system has no axiom";
    /// Unbalanced `[` / `]` in a successor, axiom or context.
    UnbalancedBrackets = "E0311", Error, "unbalanced brackets";
    /// Two phase declarations for one symbol.
    ConflictingPhase = "E0312", Error, "conflicting phase declarations";
    /// A terminal (turtle or geometry command) used as a predecessor in a sample system.
    TerminalPredecessor = "E0313", Error, "terminal used as predecessor";

    // ---- E04xx: files ----------------------------------------------------
    /// An imported `.grm` file that does not exist or cannot be read.
    ImportNotFound = "E0401", Error, "imported file not found";
    /// A mesh file that does not exist or cannot be read.
    MeshNotFound = "E0402", Error, "mesh file not found";
    /// A file that imports itself, directly or through others.
    ImportCycle = "E0403", Error, "import cycle";
    /// A file that could not be read as UTF-8 text.
    InvalidEncoding = "E0404", Error, "file is not valid UTF-8";
    /// A grammar file named on the command line that cannot be read: it
    /// does not exist, is no regular file (a directory, device or pipe), is
    /// too large, or reading it failed.
    FileUnreadable = "E0405", Error, "file cannot be read";

    // ---- E05xx: shape systems (`mode = shape`, docs/language.md 8) -------
    /// A name in a shape rule that is neither an operation nor a symbol
    /// written without arguments (`extrud(3)`).
    UnknownShapeOperation = "E0501", Error, "unknown shape operation";
    /// A shape symbol written with arguments (`Floor(3)`), in a rule or a
    /// pattern: shape symbols take none.
    ShapeSymbolArguments = "E0502", Error, "shape symbol with arguments";
    /// An operation with the wrong number of arguments (`extrude(1, 2)`).
    ShapeOperationArity = "E0503", Error, "wrong number of operation arguments";
    /// An axis, selector, roof kind, component target or asset name that
    /// does not exist (`split(w)`, `comp(faces) { frnt: A }`).
    UnknownShapeName = "E0504", Error, "unknown axis, selector or kind";
    /// A parts block where none belongs: on an operation other than
    /// `split`, `repeat` and `comp`, or in a derive or sample system.
    MisplacedParts = "E0505", Error, "parts block where none belongs";
    /// `split`, `repeat` or `comp` without parts.
    MissingParts = "E0506", Error, "shape command without parts";
    /// Sizes that can never be laid out: relative parts over 100%, a
    /// repeated tile of length zero, a negative constant size.
    SizesNeverFit = "E0507", Error, "sizes that can never fit";
    /// A component split of a shape that has no faces (or edges) there.
    CompWithoutFaces = "E0508", Error, "component split of a shape without faces";
    /// A lot that is no usable footprint: a polygon with fewer than three
    /// corners, no area, or crossing edges; a size that is not positive.
    BadLot = "E0509", Error, "unusable lot";
    /// A footprint file (`lot = "file.geojson";`) that cannot be read or
    /// holds no polygon.
    LotFileUnreadable = "E0510", Error, "lot file cannot be read";
    /// A shape system's axiom that is not one symbol.
    ShapeAxiom = "E0511", Error, "shape axiom is not one symbol";
    /// What only derive and sample systems have (contexts, module
    /// declarations, wrap-ups, an ignore list) in a shape system.
    NotInShapeSystem = "E0512", Error, "not used by shape systems";
    /// A function the shape engine does not evaluate (`atan`, `exp`, ...)
    /// in a shape rule.
    ShapeUnsupportedFunction = "E0513", Error, "function not available in shape rules";

    // ---- E06xx: city layouts (`layout NAME { ... }`; docs/layout.md) -----
    /// A layout field whose value is not a layer source (`grid(...)`,
    /// `radial(...)`, `geojson("file")`, `lsystem(System)`, `edited()`).
    LayoutUnknownSource = "E0601", Error, "not a layer source";
    /// A layer source with the wrong number or kind of arguments.
    LayoutSourceArguments = "E0602", Error, "wrong arguments to a layer source";
    /// `buildings = S;` naming a system that is not a shape system, or
    /// `lsystem(S)` one that is not a derive system.
    LayoutWrongSystemMode = "E0603", Error, "system of the wrong mode in a layout";

    // ---- W0xxx: warnings -------------------------------------------------
    /// A parameter bound in a predecessor and never used.
    UnusedParameter = "W0001", Warning, "unused parameter";
    /// A production whose predecessor can never appear in a derivation.
    UnreachableProduction = "W0002", Warning, "unreachable production";
    /// A production that an earlier production always wins over.
    ShadowedProduction = "W0003", Warning, "shadowed production";
    /// A constant or meta-parameter that nothing uses.
    UnusedDefinition = "W0004", Warning, "unused definition";
    /// Several unweighted productions for the same predecessor and condition.
    AmbiguousProductions = "W0005", Warning, "ambiguous productions";
    /// A phase declaration or wrap-up detail in a derive system, where it has no effect.
    PhaseInDerive = "W0006", Warning, "phase declaration has no effect";
    /// A file with no system in it.
    NoSystem = "W0007", Warning, "file defines no system";
    /// A condition that is constantly true or false.
    ConstantCondition = "W0008", Warning, "constant condition";
    /// A context that names a symbol of the ignore list, so it never matches.
    IgnoredInContext = "W0009", Warning, "context names an ignored symbol";
    /// A material property or `color(...)` value outside 0..1, which the model clamps.
    UnitValueClamped = "W0010", Warning, "colour or material value out of range";
    /// A never-rewritten symbol spelt like several modules without spaces
    /// (`FF` for `F F`, as the books print it).
    RunTogether = "W0011", Warning, "modules written without spaces";
    /// `[` or `]` in an ignore list: brackets are never ignored.
    BracketIgnored = "W0012", Warning, "bracket in the ignore list";
    /// A built model without a single triangle (its file would be empty).
    EmptyModel = "W0013", Warning, "model has no triangles";
    /// Instances or polygons the model builder had to leave out.
    GeometryDropped = "W0014", Warning, "geometry left out of the model";
    /// A sample-mode skeleton symbol that can neither draw a bone nor finish.
    SkeletonNeverGrows = "W0015", Warning, "skeleton symbol never draws a bone";
    /// A weight written on the only production of its group (it always applies).
    LoneWeight = "W0016", Warning, "weight of an only production";
    /// A bidirectional formatting character (U+202A to U+202E, U+2066 to
    /// U+2069) in a comment or string: the line may display in another
    /// order than it is read ("Trojan Source").
    BidiControl = "W0017", Warning, "bidirectional control character";
    /// A tag used by two commands on one path of a shape system: the
    /// semantic locator names the tag twice (`floor` inside `floor`).
    TagTwiceOnPath = "W0501", Warning, "tag used twice on one path";

    // ---- R0xxx: run time -------------------------------------------------
    // Reported by the engines after a clean check (`grmc derive`, `sample`,
    // `disasm`, the preview). Codes marked "internal" come only from a bug
    // in grm or from the environment (docs/diagnostics.md says which).

    // R01xx: compiling (grm-compile, `CompileError`)
    /// Internal: a program with checker errors reached the compiler.
    CompiledWithErrors = "R0101", Error, "compiled with errors";
    /// Internal: meta-parameter values of the wrong count or type.
    ParamValues = "R0102", Error, "meta-parameter values do not fit";
    /// A setting that is invalid for the given meta-parameter values.
    SettingForParams = "R0103", Error, "setting invalid for these meta-parameters";
    /// A constant module parameter that is NaN or infinite in 32-bit float.
    NonFiniteConstant = "R0104", Error, "constant not finite in 32-bit float";
    /// A constant weight that is not a positive finite number in 32-bit float.
    InvalidConstantWeight = "R0105", Error, "constant weight not positive and finite";
    /// An expression that needs more evaluation stack than the VM has.
    ExprNeedsTooMuchStack = "R0106", Error, "expression needs too much stack";
    /// A system whose tables do not fit the compiled format's operands.
    TablesTooLarge = "R0107", Error, "compiled tables too large";
    /// Internal: `[` or `]` in a left context (the parser never makes one).
    LeftContextBracket = "R0108", Error, "bracket in a left context";
    /// Internal: an axiom that refers to a module parameter.
    AxiomBinding = "R0109", Error, "axiom refers to a module parameter";

    // R02xx: deriving (grm-derive `DeriveError`; also grm-gpu)
    /// The next string would have more modules than the limit.
    ModuleLimit = "R0201", Error, "module limit exceeded";
    /// The next iteration would need more memory than the limit.
    MemoryLimit = "R0202", Error, "memory limit exceeded";
    /// The next string does not fit 32-bit indices.
    StringTooLarge = "R0203", Error, "string too large for 32-bit indices";
    /// A module parameter evaluated to NaN or an infinity.
    NonFiniteParameter = "R0204", Error, "parameter not finite";
    /// A weight evaluated to something that is not a positive finite number.
    InvalidWeight = "R0205", Error, "weight not positive and finite";
    /// Internal: the bytecode faulted.
    BytecodeFault = "R0206", Error, "bytecode fault";
    /// Internal: inconsistent compiled tables.
    InvalidTables = "R0207", Error, "invalid compiled tables";
    /// Internal: a module string that does not fit its system.
    InvalidModuleString = "R0208", Error, "invalid module string";
    /// Internal (environment): the worker threads could not start.
    ThreadPool = "R0209", Error, "thread pool failed";
    /// A `mode = sample` system given to classic derivation.
    NotDeriveSystem = "R0210", Error, "not a derive system";

    // R03xx: guided sampling (grm-sample, `SampleError`)
    /// `grmc sample` on a system without `mode = sample;`.
    NotSampleSystem = "R0301", Error, "not a sample system";
    /// A module parameter evaluated to NaN or an infinity while sampling.
    SampleNonFinite = "R0302", Error, "parameter not finite while sampling";
    /// A weight that is not a positive finite number while sampling.
    SampleInvalidWeight = "R0303", Error, "weight not positive and finite while sampling";
    /// Internal: the bytecode faulted while sampling.
    SampleBytecodeFault = "R0304", Error, "bytecode fault while sampling";
    /// The geometry phase went past its depth or expansion limit.
    GeometryLimit = "R0305", Error, "geometry phase limit exceeded";
    /// Internal: an expansion the turtle could not interpret.
    SampleInterpret = "R0306", Error, "expansion cannot be interpreted";
    /// Internal (environment): the sampler's worker threads could not start.
    SampleThreadPool = "R0307", Error, "thread pool failed while sampling";
    /// Sampling options that cannot be used (a volume weight <= 0, ...).
    SampleOptions = "R0308", Error, "unusable sampling options";
    /// The caller cancelled the run (`SampleOptions::cancel`); no model.
    SampleCancelled = "R0309", Error, "sampling cancelled";
    /// The search held more memory than `SampleOptions::max_bytes`
    /// (`grmc sample --max-memory`).
    SampleMemoryLimit = "R0310", Error, "sampling memory limit exceeded";

    // R04xx: building and exporting models (grm-geom)
    /// Internal: a module string the turtle cannot interpret.
    InterpretString = "R0401", Error, "string cannot be interpreted";
    /// Internal: `mesh(id)` with an id the program does not declare.
    UnknownMeshId = "R0402", Error, "unknown mesh id";
    /// Internal: `material(id)` with an id the program does not declare.
    UnknownMaterialId = "R0403", Error, "unknown material id";
    /// A declared mesh file that cannot be read.
    MeshUnreadable = "R0404", Error, "mesh file cannot be read";
    /// A declared mesh file that is not a usable OBJ mesh.
    MeshMalformed = "R0405", Error, "malformed OBJ mesh";
    /// An output path whose extension names no export format.
    UnknownExportFormat = "R0406", Error, "unknown export format";
    /// The output file could not be written.
    ExportIo = "R0407", Error, "cannot write the output file";
    /// A model too large for the output format (glb: 4 GiB).
    ModelTooLarge = "R0408", Error, "model too large for the format";

    // R05xx: guiding-curves files (grm-guide, `CurvesError`)
    /// The curves file could not be read.
    CurvesIo = "R0501", Error, "cannot read the curves file";
    /// The curves file is not JSON.
    CurvesSyntax = "R0502", Error, "curves file is not valid JSON";
    /// The curves file's `version` is not one this grm reads.
    CurvesVersion = "R0503", Error, "unsupported curves file version";
    /// A field of the curves file is missing, mistyped, unknown or out of range.
    CurvesField = "R0504", Error, "invalid field in the curves file";

    // R06xx: the GPU engine (grm-gpu, `GpuError`; limits and production
    // errors share R0201, R0202 and R0204 to R0206 with the CPU engine)
    /// Internal (environment): no GPU adapter.
    GpuNoAdapter = "R0601", Error, "no GPU adapter";
    /// Internal (environment): the adapter refused to create a device.
    GpuRequestDevice = "R0602", Error, "GPU device cannot be created";
    /// A buffer larger than the device allows.
    GpuBufferTooLarge = "R0603", Error, "GPU buffer over the device limit";
    /// A count that does not fit the kernels' 32-bit indices.
    GpuCountOverflow = "R0604", Error, "count too large for GPU indices";
    /// A dispatch needing more workgroups than the device allows.
    GpuTooManyWorkgroups = "R0605", Error, "dispatch over the device's workgroup limit";
    /// A system using something the GPU engine does not implement.
    GpuUnsupported = "R0606", Error, "not supported on the GPU";
    /// Internal: a module string with unbalanced brackets on the GPU path.
    GpuUnbalancedBrackets = "R0607", Error, "unbalanced brackets in a GPU string";
    /// Internal: malformed input to the GPU engine.
    GpuInvalidInput = "R0608", Error, "invalid GPU input";
    /// Internal (environment): wgpu reported an error.
    GpuDevice = "R0609", Error, "GPU error";
    /// Internal (environment): the device was lost.
    GpuDeviceLost = "R0610", Error, "GPU device lost";
    /// Internal (environment): reading results back from the GPU failed.
    GpuReadback = "R0611", Error, "GPU read-back failed";

    // R07xx: choosing what to run (`grmc derive`, `forest`, `sample`, `disasm`)
    /// No system to run: the file (with its imports) defines none, or none
    /// of the name given with `--system`.
    NoSystemToRun = "R0701", Error, "no system to run";

    // R08xx: growing shape systems (grm-shape `ShapeError`, through grm-grow)
    /// The derivation made more shapes than the node limit (a rule that
    /// splits forever, or a repeat of too many tiles).
    TooManyShapes = "R0801", Error, "too many shapes";
    /// A shape deeper than the depth limit (a rule that rewrites forever).
    ShapeTooDeep = "R0802", Error, "shape derivation too deep";
    /// A value a shape operation cannot use for some shape (a NaN or
    /// infinite size, a split that cannot be laid out).
    ShapeBadValue = "R0803", Error, "unusable value in a shape operation";
    /// An operation on a shape of the wrong kind at run time (faces of a
    /// face, extrusion of an edge), or `]` with nothing saved.
    ShapeWrongGeometry = "R0804", Error, "operation on the wrong kind of shape";
    /// Internal: a lowered shape program the engine refuses, or another
    /// engine limit (distinct attribute sets).
    ShapeInternal = "R0805", Error, "shape engine error";
    /// A shape system given to a command that runs bytecode (`grmc
    /// disasm`, `forest`, `sample`), or a derive system to the shape road.
    NotShapeRunnable = "R0806", Error, "not runnable this way";

    // R09xx: persistent-edits files (grm-edits, `EditsError`; docs/edits.md)
    /// The edits file could not be read (a directory, a device, too large,
    /// not UTF-8, or missing when named with `--edits`).
    EditsIo = "R0901", Error, "cannot read the edits file";
    /// The edits file is not JSON.
    EditsSyntax = "R0902", Error, "edits file is not valid JSON";
    /// The edits file's `version` is missing or not one this grm reads.
    EditsVersion = "R0903", Error, "unsupported edits file version";
    /// The file is not an object with an `edits` array, or an edit is not
    /// an object.
    EditsStructure = "R0904", Error, "malformed edits file";
    /// A field no edit (or no edit of its operation) has, or one given twice.
    EditsUnknownField = "R0905", Error, "unknown field in an edit";
    /// An edit without a field it needs (`id`, `system`, `target`, `op`,
    /// or its operation's own).
    EditsMissingField = "R0906", Error, "missing field in an edit";
    /// A field of the wrong JSON type (a string where a number belongs...).
    EditsFieldType = "R0907", Error, "field of the wrong type in an edit";
    /// An `op` that is none of the operations.
    EditsUnknownOp = "R0908", Error, "unknown edit operation";
    /// A target that is not exactly one of `exact`, `semantic` and `key`,
    /// or whose locator text does not read.
    EditsBadTarget = "R0909", Error, "invalid edit target";
    /// Two edits with the same `id`.
    EditsDuplicateId = "R0910", Error, "duplicate edit id";
    /// A value out of its range: an `id` that is not a positive integer, a
    /// `value` or `by` that is not finite, an `alternative` below 1, a
    /// pinned key that is not 8 hex digits, an empty name.
    EditsBadValue = "R0911", Error, "value out of range in an edit";

    // R10xx: city layouts (grm-layout; docs/layout.md). A bad element,
    // layer or sidecar entry is skipped; the other layers still merge.
    /// A layer's GeoJSON text is not GeoJSON (nothing of it loads).
    LayoutNotGeoJson = "R1001", Error, "layer is not GeoJSON";
    /// A GeoJSON geometry other than (Multi)LineString or Polygon.
    LayoutUnsupportedGeometry = "R1002", Error, "unsupported geometry in a layer";
    /// A street with fewer than two distinct points or both ends at one place.
    LayoutDegenerateStreet = "R1003", Error, "degenerate street";
    /// A street polyline that crosses itself.
    LayoutSelfCrossingStreet = "R1004", Error, "street crosses itself";
    /// A polygon ring whose last point is not its first.
    LayoutOpenPolygon = "R1005", Error, "open polygon";
    /// A polygon ring that crosses itself, has under three points or no area.
    LayoutBadPolygon = "R1006", Error, "self-intersecting or empty polygon";
    /// A polygon with holes (parcels are simple polygons).
    LayoutPolygonWithHoles = "R1007", Error, "parcel polygon with holes";
    /// A coordinate that is not a finite number within 1e9 m.
    LayoutNotFinite = "R1008", Error, "coordinate not finite";
    /// A `class`, `width` or `priority` property that cannot be used.
    LayoutBadProperty = "R1009", Error, "unusable element property";
    /// An element that crosses or overlaps one loaded before it.
    LayoutConflict = "R1010", Error, "element crosses an earlier one";
    /// A layer's generator parameters out of range.
    LayoutBadGenerator = "R1011", Error, "unusable generator parameters";
    /// A layer's GeoJSON file cannot be read.
    LayoutMissingFile = "R1012", Error, "layer file cannot be read";
    /// An artist's move that would make streets cross; it is not applied.
    LayoutMoveRejected = "R1013", Error, "move rejected";
    /// A deletion or protection naming an element the layer lacks.
    LayoutUnknownElement = "R1014", Error, "no such element in the layer";
    /// Internal: a merge that left an invalid layout (the layer is left out).
    LayoutMergeFailed = "R1015", Error, "merge failed";
    /// The sidecar is not JSON (nothing is read).
    SidecarSyntax = "R1021", Error, "layout file is not valid JSON";
    /// A sidecar value of the wrong type or out of range.
    SidecarBadValue = "R1022", Error, "bad value in the layout file";
    /// A key the sidecar needs is missing.
    SidecarMissing = "R1023", Error, "missing key in the layout file";
    /// A key the sidecar format does not know (ignored).
    SidecarUnknownKey = "R1024", Error, "unknown key in the layout file";
    /// An element identity that is not 16 hex digits.
    SidecarBadId = "R1025", Error, "bad element identity in the layout file";
    /// A sidecar `version` newer than this grm reads.
    SidecarVersion = "R1026", Error, "unsupported layout file version";
    /// A parcel tag naming a building meta-parameter with a value that
    /// does not fit it; the parcel stays open ground.
    BuildingTag = "R1031", Error, "parcel tag does not fit the building";
    /// A building edit (an edit with a `parcel`) whose parcel the layout
    /// no longer has, whose parcel grows no building, or that names
    /// another system than the parcels grow: reported, applied nowhere.
    BuildingEditUnplaced = "R1032", Error, "building edit has no parcel to apply to";
}

impl std::fmt::Display for Code {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::Code;
    use crate::Severity;

    /// Codes are unique, round-trip through their written form, and the
    /// letter matches the severity: `E` and `R` errors, `W` warnings.
    #[test]
    fn codes_are_unique_and_consistent() {
        let mut seen = std::collections::BTreeSet::new();
        for &c in Code::ALL {
            let s = c.as_str();
            assert!(seen.insert(s), "{s} is listed twice");
            assert_eq!(Code::from_str_code(s), Some(c));
            assert_eq!(s.len(), 5, "{s}");
            assert!(s[1..].bytes().all(|b| b.is_ascii_digit()), "{s}");
            let expected = match s.as_bytes()[0] {
                b'E' | b'R' => Severity::Error,
                b'W' => Severity::Warning,
                _ => panic!("{s}: unknown prefix"),
            };
            assert_eq!(c.severity(), expected, "{s}");
            assert!(!c.title().is_empty(), "{s}");
        }
        assert_eq!(Code::from_str_code("R9999"), None);
    }
}

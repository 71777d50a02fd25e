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
}

impl std::fmt::Display for Code {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

//! The errors of building a model ([`GeomError`]): each with its stable
//! code, the place in the grammar it names, and the help a user reads.

use super::*;

/// Why a model could not be built.
#[derive(Debug)]
pub enum GeomError {
    /// The string could not be interpreted.
    Turtle(TurtleError),
    /// `mesh(id)` with an id the program does not declare.
    UnknownMesh { id: u32, module: u32 },
    /// `material(id)` with an id the program does not declare.
    UnknownMaterial { id: u32, module: u32 },
    /// A declared mesh's file could not be read.
    MeshMissing {
        mesh: String,
        path: PathBuf,
        message: String,
    },
    /// A declared mesh's file is not a usable OBJ file.
    MeshMalformed {
        mesh: String,
        path: PathBuf,
        message: String,
    },
    /// Meta-parameter values that do not fit the program (wrong count or
    /// type): a caller's mistake, never the user's.
    Params(String),
    /// Building the model (and writing it as `output` says) would need
    /// `footprint.bytes`, more than `limit` ([`BuildOptions::max_bytes`]);
    /// nothing was built. R0202, as a derivation over its memory limit.
    MemoryLimit {
        footprint: Footprint,
        limit: u64,
        output: Output,
    },
    /// Shape mode: a material, insert asset or texture name of the shape
    /// program that the [`shape::ShapeAssets`] do not resolve (`what`:
    /// `material`, `asset` or `texture`).
    UnknownShapeName { what: &'static str, name: String },
    /// Shape mode: a texture's image could not be read, or is not a PNG
    /// or JPEG file.
    TextureUnreadable {
        texture: String,
        path: PathBuf,
        message: String,
    },
}

impl std::fmt::Display for GeomError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GeomError::Turtle(e) => write!(f, "{e}"),
            GeomError::UnknownMesh { id, module } => {
                write!(
                    f,
                    "module {module} draws mesh #{id}, which the program does not declare"
                )
            }
            GeomError::UnknownMaterial { id, module } => write!(
                f,
                "module {module} uses material #{id}, which the program does not declare"
            ),
            GeomError::MeshMissing {
                mesh,
                path,
                message,
            } => write!(
                f,
                "cannot read mesh `{mesh}` from {}: {message}",
                path.display()
            ),
            GeomError::MeshMalformed {
                mesh,
                path,
                message,
            } => write!(
                f,
                "mesh `{mesh}` in {} is not a valid OBJ file: {message}",
                path.display()
            ),
            GeomError::Params(m) => write!(f, "meta-parameter values do not fit: {m}"),
            GeomError::MemoryLimit {
                footprint,
                limit,
                output,
            } => write!(f, "{}", footprint.message(*limit, *output)),
            GeomError::UnknownShapeName { what, name } => {
                write!(
                    f,
                    "the shape grammar uses {what} `{name}`, which is not declared"
                )
            }
            GeomError::TextureUnreadable {
                texture,
                path,
                message,
            } => write!(
                f,
                "cannot read texture `{texture}` from {}: {message}",
                path.display()
            ),
        }
    }
}

impl GeomError {
    /// The stable code: `R04xx`.
    pub fn code(&self) -> Code {
        match self {
            GeomError::Turtle(_) => Code::InterpretString,
            GeomError::UnknownMesh { .. } => Code::UnknownMeshId,
            GeomError::UnknownMaterial { .. } => Code::UnknownMaterialId,
            GeomError::MeshMissing { .. } => Code::MeshUnreadable,
            GeomError::MeshMalformed { .. } => Code::MeshMalformed,
            GeomError::Params(_) => Code::ParamValues,
            GeomError::MemoryLimit { .. } => Code::MemoryLimit,
            GeomError::UnknownShapeName {
                what: "material", ..
            } => Code::UnknownMaterialId,
            GeomError::UnknownShapeName { .. } => Code::UnknownMeshId,
            GeomError::TextureUnreadable { .. } => Code::MeshUnreadable,
        }
    }

    /// The error as a diagnostic. A mesh file's problem points at the
    /// mesh's declaration in `program` and names the file as written there;
    /// the others point at `file`/`span`, the system whose model was being
    /// built.
    pub fn to_diagnostic(&self, program: &Program, file: FileId, span: Span) -> Diagnostic {
        let (mesh, message, help) = match self {
            GeomError::MemoryLimit { .. } => {
                return Diagnostic::new(
                    self.code(),
                    self.to_string(),
                    file,
                    span,
                    "while building the model of this system",
                )
                .with_help(MEMORY_HELP);
            }
            GeomError::UnknownShapeName { .. } | GeomError::TextureUnreadable { .. } => {
                let help = match self {
                    GeomError::TextureUnreadable { .. } => {
                        "a texture names a PNG or JPEG image; make the file readable and run again"
                    }
                    _ => {
                        "declare it (`material NAME { ... }`, `mesh NAME = \"file.obj\";`) or use one of the primitives box, cylinder, cone, sphere, disc"
                    }
                };
                return Diagnostic::new(
                    self.code(),
                    self.to_string(),
                    file,
                    span,
                    "while building the model of this system",
                )
                .with_help(help);
            }
            GeomError::MeshMissing { mesh, message, .. } => (mesh, message, MESH_MISSING_HELP),
            GeomError::MeshMalformed { mesh, message, .. } => (mesh, message, MESH_MALFORMED_HELP),
            GeomError::Turtle(_)
            | GeomError::UnknownMesh { .. }
            | GeomError::UnknownMaterial { .. }
            | GeomError::Params(_) => {
                let label = "while building the model of this system";
                return Diagnostic::new(self.code(), self.to_string(), file, span, label)
                    .with_help(INTERNAL_HELP);
            }
        };
        let Some(m) = program.meshes.iter().find(|m| &m.name == mesh) else {
            return Diagnostic::new(self.code(), self.to_string(), file, span, "in this model")
                .with_help(help);
        };
        let text = match self {
            GeomError::MeshMissing { .. } => {
                format!(
                    "cannot read mesh `{mesh}` from \"{}\": {message}",
                    m.written
                )
            }
            _ => format!(
                "mesh `{mesh}` in \"{}\" is not a valid OBJ file: {message}",
                m.written
            ),
        };
        Diagnostic::new(
            self.code(),
            text,
            m.loc.file,
            m.loc.span,
            "this mesh's file",
        )
        .with_help(help)
    }
}

pub(crate) const MESH_MISSING_HELP: &str = "mesh paths are relative to the directory of the file that \
     declares them; make the file readable and run again";
pub(crate) const MESH_MALFORMED_HELP: &str =
    "save the mesh as an OBJ file of triangles or polygons with at least one face";
pub(crate) const MEMORY_HELP: &str = "derive fewer iterations (`-n`) or plant fewer trees, draw \
     fewer bones (a coarser grammar), or raise the limit (`--max-memory MIB`)";
pub(crate) const INTERNAL_HELP: &str =
    "this is an internal error of grm; please report it with the file that caused it";

impl std::error::Error for GeomError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            GeomError::Turtle(e) => Some(e),
            _ => None,
        }
    }
}

impl From<TurtleError> for GeomError {
    fn from(e: TurtleError) -> Self {
        GeomError::Turtle(e)
    }
}

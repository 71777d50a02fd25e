//! Reading imported grammars and checking that mesh files exist, behind a
//! trait so tests and the language server can supply files from memory.

use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};

/// Why a file could not be loaded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LoadError {
    /// No such file (or it cannot be opened).
    NotFound,
    /// The file is not valid UTF-8.
    NotUtf8,
    /// Any other I/O error, with its message.
    Other(String),
}

/// Where the checker gets files from.
pub trait FileLoader {
    /// Read a `.grm` file's text.
    fn read(&self, path: &Path) -> Result<String, LoadError>;

    /// Whether a file (a mesh) exists and can be read.
    fn exists(&self, path: &Path) -> bool;

    /// Why `path`, for which [`FileLoader::exists`] is false, cannot be
    /// used: the label of the diagnostic.
    fn why_missing(&self, _path: &Path) -> &'static str {
        "no such file"
    }

    /// Resolve `written` (as written in an import or mesh declaration)
    /// relative to the directory of the file `from`.
    fn resolve(&self, from: &Path, written: &str) -> PathBuf {
        let base = from.parent().unwrap_or(Path::new(""));
        normalize(&base.join(written))
    }
}

/// The real file system. Paths are made absolute against the current
/// directory.
#[derive(Clone, Copy, Debug, Default)]
pub struct FsLoader;

/// The largest `.grm` file [`FsLoader`] reads (a 1,000-line grammar is
/// about 30 KiB): an `import` of something else (a huge data file by
/// mistake) is refused instead of filling memory.
pub const MAX_SOURCE_BYTES: u64 = 16 << 20;

impl FileLoader for FsLoader {
    /// Only regular files are read (`grm_diag::input::read_bounded`, as
    /// for every file a user names): an `import` of `/dev/zero` would read
    /// forever, one of a named pipe wait forever, and one of `/dev/stdin`
    /// in the language server would eat its protocol stream.
    fn read(&self, path: &Path) -> Result<String, LoadError> {
        let bytes = grm_diag::input::read_bounded(path, MAX_SOURCE_BYTES, "a grammar file")
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::NotFound => LoadError::NotFound,
                _ => LoadError::Other(e.to_string()),
            })?;
        String::from_utf8(bytes).map_err(|_| LoadError::NotUtf8)
    }

    fn exists(&self, path: &Path) -> bool {
        path.is_file()
    }

    fn why_missing(&self, path: &Path) -> &'static str {
        match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => "it is a directory",
            Ok(_) => "it is not a regular file",
            Err(_) => "no such file",
        }
    }

    fn resolve(&self, from: &Path, written: &str) -> PathBuf {
        let base = from.parent().unwrap_or(Path::new(""));
        let joined = base.join(written);
        normalize(&std::path::absolute(&joined).unwrap_or(joined))
    }
}

/// Files held in memory (tests, editor buffers). Paths are normalized
/// lexically on insertion and lookup.
#[derive(Clone, Debug, Default)]
pub struct MemLoader {
    files: HashMap<PathBuf, Option<String>>,
}

impl MemLoader {
    pub fn new() -> MemLoader {
        MemLoader::default()
    }

    /// Add a text file.
    pub fn add(&mut self, path: impl AsRef<Path>, text: impl Into<String>) -> &mut Self {
        self.files
            .insert(normalize(path.as_ref()), Some(text.into()));
        self
    }

    /// Add a file that exists but is not UTF-8 text (a mesh, or a broken grammar).
    pub fn add_binary(&mut self, path: impl AsRef<Path>) -> &mut Self {
        self.files.insert(normalize(path.as_ref()), None);
        self
    }
}

impl FileLoader for MemLoader {
    fn read(&self, path: &Path) -> Result<String, LoadError> {
        match self.files.get(&normalize(path)) {
            Some(Some(t)) => Ok(t.clone()),
            Some(None) => Err(LoadError::NotUtf8),
            None => Err(LoadError::NotFound),
        }
    }

    fn exists(&self, path: &Path) -> bool {
        self.files.contains_key(&normalize(path))
    }
}

/// Remove `.` components and resolve `..` lexically (without touching the
/// file system).
pub fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    let mut depth = 0usize; // normal components that `..` may remove
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if depth > 0 {
                    out.pop();
                    depth -= 1;
                } else if !out.has_root() {
                    out.push("..");
                }
            }
            Component::Normal(s) => {
                out.push(s);
                depth += 1;
            }
            Component::RootDir | Component::Prefix(_) => {
                out.push(c.as_os_str());
                depth = 0;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalizes_lexically() {
        assert_eq!(
            normalize(Path::new("a/./b/../c.grm")),
            PathBuf::from("a/c.grm")
        );
        assert_eq!(normalize(Path::new("../x/../y")), PathBuf::from("../y"));
        assert_eq!(normalize(Path::new("/a/../../b")), PathBuf::from("/b"));
    }

    #[test]
    fn mem_loader_resolves_relative_to_importer() {
        let mut m = MemLoader::new();
        m.add("dir/common.grm", "const A = 1;");
        let p = m.resolve(Path::new("dir/main.grm"), "./common.grm");
        assert_eq!(m.read(&p).unwrap(), "const A = 1;");
    }
}

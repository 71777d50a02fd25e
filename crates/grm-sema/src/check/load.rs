//! Loading a program's import closure: each file read and parsed once,
//! imports resolved relative to their file, cycles reported, and the
//! files' load order (see the parent module).

use super::*;

/// One parsed file of the import closure.
pub(crate) struct LoadedFile {
    pub id: FileId,
    /// The path used to read files relative to this one.
    pub real: PathBuf,
    pub ast: ast::File,
    /// Files this one imports directly (indices into the loaded files).
    pub imports: Vec<usize>,
    /// Each import that loaded a file: the path's span and the file
    /// (for [`crate::Program::imports`]).
    pub edges: Vec<(Span, FileId)>,
    /// Whether the parser reported errors in it.
    pub broken: bool,
    /// Whether one of its imports could not be read (E0401, E0404): names
    /// it does not know may be defined there, and are not reported.
    pub failed_import: bool,
    /// Primary spans of the parser's diagnostics (to avoid follow-on reports).
    pub error_spans: Vec<Span>,
}

/// Load the root and everything it imports, parsing each file once.
pub(crate) fn load_all(
    sources: &mut SourceMap,
    root: FileId,
    loader: &dyn FileLoader,
    diags: &mut Vec<Diagnostic>,
) -> Vec<LoadedFile> {
    let root_file = sources.get(root);
    let root_display = root_file.path.clone();
    let real = loader.resolve(Path::new(""), &root_display);
    // The root is parsed from the source map's text, not a copy of it
    // (a second copy of a large file while its tree is built: issue 32).
    let parsed = grm_syntax::parse(root, &root_file.text);
    let mut l = Loader {
        sources,
        loader,
        diags,
        files: Vec::new(),
        by_path: HashMap::new(),
        state: Vec::new(),
        stack: Vec::new(),
    };
    l.load(root, real, parsed);
    l.files
}

pub(super) struct Loader<'a> {
    pub(super) sources: &'a mut SourceMap,
    pub(super) loader: &'a dyn FileLoader,
    pub(super) diags: &'a mut Vec<Diagnostic>,
    pub(super) files: Vec<LoadedFile>,
    pub(super) by_path: HashMap<PathBuf, usize>,
    /// Per file: still loading its imports (on the stack).
    pub(super) state: Vec<bool>,
    pub(super) stack: Vec<usize>,
}

impl Loader<'_> {
    /// Load a file and, depth first, everything it imports. Iterative (an
    /// explicit stack of open files), so a long import chain cannot
    /// exhaust the call stack.
    pub(super) fn load(&mut self, id: FileId, real: PathBuf, parsed: grm_syntax::Parsed) -> usize {
        let root = self.open(id, real, parsed);
        // Per open file: its imports and how many of them were handled.
        let mut open = vec![(root, self.imports_of(root), 0usize)];
        while let Some((idx, imports, next)) = open.last_mut() {
            let idx = *idx;
            let Some(imp) = imports.get(*next).cloned() else {
                open.pop();
                self.stack.pop();
                self.state[idx] = false;
                continue;
            };
            *next += 1;
            if let Some(t) = self.import(idx, &imp) {
                open.push((t, self.imports_of(t), 0));
            }
        }
        root
    }

    /// Put a parsed file on the stack of files being loaded.
    pub(super) fn open(&mut self, id: FileId, real: PathBuf, parsed: grm_syntax::Parsed) -> usize {
        let broken = parsed.has_errors();
        let error_spans = parsed
            .diagnostics
            .iter()
            .map(|d| d.primary().span)
            .collect();
        self.diags.extend(parsed.diagnostics);
        let idx = self.files.len();
        self.files.push(LoadedFile {
            id,
            real: real.clone(),
            ast: parsed.file,
            imports: Vec::new(),
            edges: Vec::new(),
            broken,
            failed_import: false,
            error_spans,
        });
        self.by_path.insert(real, idx);
        self.state.push(true);
        self.stack.push(idx);
        idx
    }

    pub(super) fn imports_of(&self, idx: usize) -> Vec<ast::Import> {
        self.files[idx]
            .ast
            .items
            .iter()
            .filter_map(|it| match it {
                Item::Import(i) => Some(i.clone()),
                _ => None,
            })
            .collect()
    }

    /// Handle one import of file `idx`. Returns the imported file if it was
    /// newly opened (its imports are to be loaded next).
    pub(super) fn import(&mut self, idx: usize, imp: &ast::Import) -> Option<usize> {
        let id = self.files[idx].id;
        let real = self.files[idx].real.clone();
        let display = self.sources.get(id).path.clone();
        let written = &imp.path.value;
        if overlaps_any(&self.files[idx].error_spans, imp.path.span) {
            return None; // a garbled path was reported by the parser
        }
        if written.trim().is_empty() {
            // Joined to the importing file's directory, it would name that
            // directory ("it is a directory").
            self.files[idx].failed_import = true;
            self.diags.push(
                Diagnostic::new(
                    Code::ImportNotFound,
                    "the import path is empty",
                    id,
                    imp.path.span,
                    "empty path",
                )
                .with_help("write the path of a `.grm` file, relative to the directory of the importing file, e.g. `import \"common.grm\";`"),
            );
            return None;
        }
        let target_real = self.loader.resolve(&real, written);
        if let Some(&t) = self.by_path.get(&target_real) {
            let to = self.files[t].id;
            self.files[idx].edges.push((imp.path.span, to));
            if self.state[t] {
                // On the stack: a cycle.
                let start = self.stack.iter().position(|&s| s == t).unwrap_or(0);
                let chain: Vec<String> = self.stack[start..]
                    .iter()
                    .chain(std::iter::once(&t))
                    .map(|&f| format!("`{}`", self.sources.get(self.files[f].id).path))
                    .collect();
                self.diags.push(
                    Diagnostic::new(
                        Code::ImportCycle,
                        format!("importing `{written}` here closes an import cycle"),
                        id,
                        imp.path.span,
                        "this import closes a cycle",
                    )
                    .with_note(format!("import chain: {}", chain.join(" -> ")))
                    .with_help("move the shared definitions into a third file that both import"),
                );
                // Names stay visible, so the cycle is the only error.
                self.files[idx].imports.push(t);
            } else if !self.files[idx].imports.contains(&t) {
                self.files[idx].imports.push(t);
            }
            return None;
        }
        let target_display = normalize(
            &Path::new(&display)
                .parent()
                .unwrap_or(Path::new(""))
                .join(written),
        )
        .to_string_lossy()
        .replace('\\', "/");
        let text = match self.sources.find(&target_display) {
            Some(existing) => Ok(self.sources.get(existing).text.clone()),
            None => self.loader.read(&target_real),
        };
        match text {
            Ok(text) => {
                let fid = match self.sources.find(&target_display) {
                    Some(f) => f,
                    None => self.sources.add(target_display, text.clone()),
                };
                let t = self.open(fid, target_real, grm_syntax::parse(fid, &text));
                self.files[idx].imports.push(t);
                self.files[idx].edges.push((imp.path.span, fid));
                Some(t)
            }
            Err(e) => {
                let (code, msg, label) = match e {
                    LoadError::NotFound => (
                        Code::ImportNotFound,
                        format!("cannot find the imported file `{written}`"),
                        "no such file".to_string(),
                    ),
                    LoadError::NotUtf8 => (
                        Code::InvalidEncoding,
                        format!("the imported file `{written}` is not valid UTF-8 text"),
                        "not UTF-8".to_string(),
                    ),
                    LoadError::Other(m) => (
                        Code::ImportNotFound,
                        format!("cannot read the imported file `{written}`"),
                        m,
                    ),
                };
                self.files[idx].failed_import = true;
                let mut d = Diagnostic::new(code, msg, id, imp.path.span, label);
                if code == Code::ImportNotFound {
                    d = d.with_help(
                        "import paths are relative to the directory of the importing file",
                    );
                }
                self.diags.push(d);
                None
            }
        }
    }
}

/// Each file's place in load order: a file comes after everything it
/// imports (a depth-first post-order from the root, imports in the order
/// written; in a cycle, the file reached first comes last), as if each
/// `import` were replaced by the imported file's text.
pub(crate) fn load_order(files: &[LoadedFile]) -> Vec<usize> {
    let n = files.len();
    let mut rank = vec![0; n];
    let mut seen = vec![false; n];
    let mut next = 0;
    for start in 0..n {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let mut stack = vec![(start, 0usize)];
        while let Some((f, i)) = stack.last_mut() {
            let f = *f;
            if let Some(&g) = files[f].imports.get(*i) {
                *i += 1;
                if !seen[g] {
                    seen[g] = true;
                    stack.push((g, 0));
                }
            } else {
                rank[f] = next;
                next += 1;
                stack.pop();
            }
        }
    }
    rank
}

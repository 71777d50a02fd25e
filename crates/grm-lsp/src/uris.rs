//! Document URIs as the client spells them.
//!
//! Clients spell the URI of one file differently: VS Code percent-encodes
//! everything but letters, digits and `-._~/` (and the drive colon:
//! `file:///c%3A/...`), others leave `+`, `:` or parentheses as they are, or
//! write lowercase hex digits. Inside the server a document is known by its
//! path ([`path_of`]), so every spelling of a file is the same document.
//! Answers go back under the spelling the client used: [`Uris`] remembers the
//! URI each open document was opened under and the workspace folders as the
//! client sent them, and [`Uris::uri_of`] names a path with them. Only a file
//! the client has neither open nor under one of its folders gets a spelling
//! of the server's own ([`file_uri`]).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tower_lsp_server::ls_types::Uri;

/// Documents that are not files (`untitled:` buffers) live under this
/// made-up directory, their URI hex-encoded as the file name.
const VIRTUAL: &str = "/.grm-virtual/";

/// The client's spelling of URIs: a snapshot, cheap to clone and to send to
/// a blocking task.
#[derive(Clone, Debug, Default)]
pub struct Uris {
    /// The URI each open document was opened under, by its path.
    open: Arc<HashMap<PathBuf, Uri>>,
    /// The workspace folders: their path, and their URI as the client sent
    /// it, without a trailing `/`. Longest path first.
    roots: Arc<Vec<(PathBuf, String)>>,
}

impl Uris {
    /// `path` is open under `uri`.
    pub fn open(&mut self, path: PathBuf, uri: Uri) {
        Arc::make_mut(&mut self.open).insert(path, uri);
    }

    /// `path` is no longer open.
    pub fn close(&mut self, path: &Path) {
        if self.open.contains_key(path) {
            Arc::make_mut(&mut self.open).remove(path);
        }
    }

    /// The workspace folders, as the client sent them. Returns their paths.
    pub fn set_roots<'a>(&mut self, folders: impl IntoIterator<Item = &'a Uri>) -> Vec<PathBuf> {
        let mut paths = Vec::new();
        let mut roots = Vec::new();
        for uri in folders {
            let Some(path) = file_path_of(uri) else {
                continue;
            };
            paths.push(path.clone());
            // A folder with a query or fragment cannot be extended by a path.
            if uri.query().is_none() && uri.fragment().is_none() {
                let text = uri.as_str().trim_end_matches('/').to_string();
                roots.push((path, text));
            }
        }
        roots.sort_by_key(|(p, _)| std::cmp::Reverse(p.components().count()));
        self.roots = Arc::new(roots);
        paths
    }

    /// The URI to name `path` by: the one it is open under; else under the
    /// workspace folder that holds it, spelt as the client spelt the folder;
    /// else the server's own spelling ([`uri_of`]).
    pub fn uri_of(&self, path: &Path) -> Option<Uri> {
        if let Some(u) = self.open.get(path) {
            return Some(u.clone());
        }
        if !path.starts_with(VIRTUAL) {
            for (root, text) in self.roots.iter() {
                if let Some(u) = under(text, root, path) {
                    return Some(u);
                }
            }
        }
        uri_of(path)
    }
}

/// `path` as a URI under the folder `root`, whose URI is `text`.
fn under(text: &str, root: &Path, path: &Path) -> Option<Uri> {
    let rest = path.strip_prefix(root).ok()?;
    let mut s = text.to_string();
    for c in rest.components() {
        let std::path::Component::Normal(name) = c else {
            return None; // normalized paths have no `.` or `..`
        };
        s.push('/');
        encode_into(&mut s, os_bytes(name)?.as_ref(), false);
    }
    s.parse().ok()
}

/// The path a document is known by: a local `file:` URI's path (decoded
/// byte for byte, normalized), or a made-up path for other URIs (so that
/// unsaved buffers are analysed too; their imports resolve nowhere). Every
/// spelling of one file's URI gives the same path.
pub fn path_of(uri: &Uri) -> Option<PathBuf> {
    if let Some(p) = file_path_of(uri) {
        return Some(p);
    }
    let hex: String = uri.as_str().bytes().map(|b| format!("{b:02x}")).collect();
    Some(PathBuf::from(format!("{VIRTUAL}{hex}")))
}

/// The normalized path of a `file:` URI naming a file of this machine.
fn file_path_of(uri: &Uri) -> Option<PathBuf> {
    if !uri.scheme().as_str().eq_ignore_ascii_case("file") {
        return None;
    }
    local_path(uri).map(|p| grm_sema::normalize(&p))
}

#[cfg(unix)]
fn local_path(uri: &Uri) -> Option<PathBuf> {
    use std::os::unix::ffi::OsStringExt;
    // `file://host/...` names a file of another machine.
    let host = uri.authority().map(|a| a.host()).unwrap_or_default();
    if !host.is_empty() && !host.eq_ignore_ascii_case("localhost") {
        return None;
    }
    // Byte for byte: names need not be UTF-8, and two that are not must
    // not become one (a lossy decoding would make both U+FFFD).
    let bytes = uri.path().decode().to_bytes().into_owned();
    if bytes.first() != Some(&b'/') {
        return None;
    }
    Some(PathBuf::from(std::ffi::OsString::from_vec(bytes)))
}

#[cfg(not(unix))]
fn local_path(uri: &Uri) -> Option<PathBuf> {
    // Windows paths are Unicode: a name that does not decode to UTF-8
    // names no file (the document is analysed under a made-up path).
    uri.path().decode().to_string().ok()?;
    let p = uri.to_file_path()?.into_owned();
    Some(upper_drive(p))
}

/// `c:\x` as `C:\x`: clients disagree on the drive letter's case (VS Code
/// writes it lowercase), and it names the same file.
#[cfg(not(unix))]
fn upper_drive(p: PathBuf) -> PathBuf {
    let Some(s) = p.to_str() else { return p };
    let b = s.as_bytes();
    if b.len() >= 2 && b[0].is_ascii_lowercase() && b[1] == b':' {
        let mut t = s.to_string();
        t[..1].make_ascii_uppercase();
        return PathBuf::from(t);
    }
    p
}

/// The URI of a path in the server's own spelling (for a file the client
/// has not named): a file's `file:` URI, percent-encoded as VS Code does
/// (everything but ASCII letters, digits and `-._~/`, uppercase hex), or a
/// non-file document's original URI.
pub fn uri_of(path: &Path) -> Option<Uri> {
    if let Some(hex) = path.to_str().and_then(|s| s.strip_prefix(VIRTUAL)) {
        let bytes: Option<Vec<u8>> = (0..hex.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(hex.get(i..i + 2)?, 16).ok())
            .collect();
        let text = String::from_utf8(bytes?).ok()?;
        return text.parse().ok();
    }
    file_uri(path)
}

/// A `file:` URI for a path (a relative one against the current directory).
#[cfg(unix)]
pub fn file_uri(path: &Path) -> Option<Uri> {
    use std::os::unix::ffi::OsStrExt;
    let path = std::path::absolute(path).ok()?;
    let mut s = String::from("file://");
    encode_into(&mut s, path.as_os_str().as_bytes(), true);
    s.parse().ok()
}

/// A `file:` URI for a path (a relative one against the current directory).
#[cfg(not(unix))]
pub fn file_uri(path: &Path) -> Option<Uri> {
    Uri::from_file_path(std::path::absolute(path).ok()?)
}

#[cfg(unix)]
fn os_bytes(s: &std::ffi::OsStr) -> Option<std::borrow::Cow<'_, [u8]>> {
    use std::os::unix::ffi::OsStrExt;
    Some(std::borrow::Cow::Borrowed(s.as_bytes()))
}

#[cfg(not(unix))]
fn os_bytes(s: &std::ffi::OsStr) -> Option<std::borrow::Cow<'_, [u8]>> {
    s.to_str().map(|s| std::borrow::Cow::Borrowed(s.as_bytes()))
}

/// Percent-encode `bytes` onto `out`: all but ASCII letters, digits and
/// `-._~` (and `/` when `slash`).
fn encode_into(out: &mut String, bytes: &[u8], slash: bool) {
    const HEX: &[u8; 16] = b"0123456789ABCDEF";
    for &b in bytes {
        if b.is_ascii_alphanumeric()
            || matches!(b, b'-' | b'.' | b'_' | b'~')
            || (slash && b == b'/')
        {
            out.push(b as char);
        } else {
            out.push('%');
            out.push(HEX[usize::from(b >> 4)] as char);
            out.push(HEX[usize::from(b & 15)] as char);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn uri(s: &str) -> Uri {
        s.parse().expect("valid URI")
    }

    #[test]
    fn spellings_of_one_file_are_one_path() {
        let a = path_of(&uri("file:///home/x/My%20Grammars/a%2Bb.grm"));
        for s in [
            "file:///home/x/My%20Grammars/a+b.grm",
            "file:///home/x/My%20Grammars/a%2bb.grm",
            "file://localhost/home/x/My%20Grammars/a+b.grm",
            "file:///home/x/./My%20Grammars/../My%20Grammars/a+b.grm",
            "FILE:///home/x/My%20Grammars/a+b.grm",
        ] {
            assert_eq!(path_of(&uri(s)), a, "{s}");
        }
    }

    #[cfg(unix)]
    #[test]
    fn paths_decode_byte_for_byte() {
        use std::os::unix::ffi::OsStrExt;
        let p = path_of(&uri("file:///x/%FF%C3%A9.grm")).expect("a path");
        assert_eq!(p.as_os_str().as_bytes(), b"/x/\xff\xc3\xa9.grm");
        assert_eq!(
            uri_of(&p).map(|u| u.as_str().to_string()),
            Some("file:///x/%FF%C3%A9.grm".to_string())
        );
        // Another machine's file is no file here.
        let remote = path_of(&uri("file://server/share/a.grm")).expect("a path");
        assert!(remote.starts_with(VIRTUAL), "{remote:?}");
    }

    #[test]
    fn open_documents_keep_their_spelling() {
        let mut u = Uris::default();
        let s = "file:///c%3A/Users/x/a+b%20(1).grm";
        let p = path_of(&uri(s)).expect("a path");
        assert_ne!(
            uri_of(&p).map(|u| u.as_str().to_string()).as_deref(),
            Some(s)
        );
        u.open(p.clone(), uri(s));
        assert_eq!(
            u.uri_of(&p).map(|u| u.as_str().to_string()).as_deref(),
            Some(s)
        );
        u.close(&p);
        assert_eq!(u.uri_of(&p), uri_of(&p));
    }

    #[cfg(unix)] // Unix paths
    #[test]
    fn files_under_a_folder_use_its_spelling() {
        let mut u = Uris::default();
        let folders = [
            uri("file:///home/x/a+b/"),
            uri("file:///home/x/a+b/in%20ner"),
        ];
        let paths = u.set_roots(&folders);
        assert_eq!(paths.len(), 2);
        let named = |p: &str| u.uri_of(Path::new(p)).map(|u| u.as_str().to_string());
        assert_eq!(
            named("/home/x/a+b/sub dir/t.grm").as_deref(),
            Some("file:///home/x/a+b/sub%20dir/t.grm")
        );
        // The innermost folder wins.
        assert_eq!(
            named("/home/x/a+b/in ner/t+1.grm").as_deref(),
            Some("file:///home/x/a+b/in%20ner/t%2B1.grm")
        );
        // Outside every folder: the server's own spelling.
        assert_eq!(
            named("/home/y/a+b.grm").as_deref(),
            Some("file:///home/y/a%2Bb.grm")
        );
    }

    #[test]
    fn untitled_buffers_round_trip() {
        let u = uri("untitled:Untitled-1");
        let p = path_of(&u).expect("a path");
        assert_eq!(uri_of(&p), Some(u.clone()));
        assert_eq!(Uris::default().uri_of(&p), Some(u));
    }
}

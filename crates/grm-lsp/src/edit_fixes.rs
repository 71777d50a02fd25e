//! Quick fixes on an edits file (docs/edits.md, "In the editor"): delete
//! an edit, and retarget one whose target no longer names what it did
//! (the candidates a preview proposed: shape mode's by
//! `grm_grow::shape::retarget`, derive and sample mode's keys by
//! `grm_grow::retarget`; each a code action the artist picks, never
//! applied by itself). Also
//! the tolerant scan of the file's text that finds each edit's element,
//! so an edit that does not read can still be cut out.

use crate::edits::{EditOut, RetargetOut, read};
use crate::{Backend, Shared, convert, failed};
use grm_diag::{SourceFile, Span};
use grm_edits::Target;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

// ---------------------------------------------------------------------
// The layout of an edits file's text: where each element of `edits` is.

/// Where the `edits` array and its elements are in a text (found by a
/// tolerant scan: strings and nesting are followed, nothing else checked).
#[derive(Debug, Default, PartialEq)]
pub(crate) struct Layout {
    /// After the array's `[` and at its `]`.
    pub(crate) inside: Option<(usize, usize)>,
    /// Each element's byte range.
    pub(crate) elements: Vec<(usize, usize)>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Tok {
    Open(u8),
    Close(u8),
    Colon,
    Comma,
    Str,
    Other,
}

fn tokens(text: &str) -> Vec<(Tok, usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let start = i;
        let tok = match c {
            b' ' | b'\t' | b'\r' | b'\n' => {
                i += 1;
                continue;
            }
            b'{' | b'[' => Tok::Open(c),
            b'}' | b']' => Tok::Close(c),
            b':' => Tok::Colon,
            b',' => Tok::Comma,
            b'"' => {
                i += 1;
                while i < b.len() && b[i] != b'"' {
                    i += if b[i] == b'\\' { 2 } else { 1 };
                }
                out.push((Tok::Str, start, (i + 1).min(b.len())));
                i += 1;
                continue;
            }
            _ => {
                while i < b.len() && !b" \t\r\n{}[]:,\"".contains(&b[i]) {
                    i += 1;
                }
                out.push((Tok::Other, start, i));
                continue;
            }
        };
        i += 1;
        out.push((tok, start, i));
    }
    out
}

/// The index after the value starting at token `i` (nested values
/// followed to their close).
fn skip_value(toks: &[(Tok, usize, usize)], i: usize) -> usize {
    match toks.get(i) {
        Some((Tok::Open(_), ..)) => {
            let mut depth = 0usize;
            let mut j = i;
            while j < toks.len() {
                match toks[j].0 {
                    Tok::Open(_) => depth += 1,
                    Tok::Close(_) => {
                        depth -= 1;
                        if depth == 0 {
                            return j + 1;
                        }
                    }
                    _ => {}
                }
                j += 1;
            }
            j
        }
        Some(_) => i + 1,
        None => i,
    }
}

/// The layout of an edits file's text.
pub(crate) fn layout(text: &str) -> Layout {
    let toks = tokens(text);
    let mut out = Layout::default();
    if !matches!(toks.first(), Some((Tok::Open(b'{'), ..))) {
        return out;
    }
    let mut i = 1;
    while i < toks.len() {
        let (t, s, e) = toks[i];
        if t == Tok::Comma {
            i += 1;
            continue;
        }
        if t != Tok::Str || toks.get(i + 1).map(|t| t.0) != Some(Tok::Colon) {
            return out;
        }
        let key = &text[s..e];
        let v = i + 2;
        if key == "\"edits\"" && matches!(toks.get(v), Some((Tok::Open(b'['), ..))) {
            let end = skip_value(&toks, v);
            let close = toks
                .get(end.saturating_sub(1))
                .filter(|t| t.0 == Tok::Close(b']'))
                .map_or(text.len(), |t| t.1);
            out.inside = Some((toks[v].2, close));
            let mut j = v + 1;
            while j < end.saturating_sub(1) {
                if toks[j].0 == Tok::Comma {
                    j += 1;
                    continue;
                }
                let k = skip_value(&toks, j).max(j + 1);
                out.elements.push((toks[j].1, toks[k - 1].2));
                j = k;
            }
            return out;
        }
        i = skip_value(&toks, v);
    }
    out
}

/// The text edit that removes element `at` of the `edits` array, with
/// the comma and white space between it and its neighbour.
fn remove_element(lay: &Layout, at: usize) -> Option<(Span, String)> {
    let (s, e) = *lay.elements.get(at)?;
    let span = if let Some(next) = lay.elements.get(at + 1) {
        (s, next.0)
    } else if let Some(prev) = at.checked_sub(1).and_then(|p| lay.elements.get(p)) {
        (prev.1, e)
    } else {
        lay.inside.unwrap_or((s, e))
    };
    Some((Span::from_range(span.0..span.1), String::new()))
}

/// The smallest edit that turns `old` into `new`: their common start and
/// end kept (on character boundaries).
pub(crate) fn minimal_edit(old: &str, new: &str) -> (Span, String) {
    let (a, b) = (old.as_bytes(), new.as_bytes());
    let mut p = a.iter().zip(b).take_while(|(x, y)| x == y).count();
    while !old.is_char_boundary(p) || !new.is_char_boundary(p) {
        p -= 1;
    }
    let max = (a.len() - p).min(b.len() - p);
    let mut s = a
        .iter()
        .rev()
        .zip(b.iter().rev())
        .take(max)
        .take_while(|(x, y)| x == y)
        .count();
    while !old.is_char_boundary(a.len() - s) || !new.is_char_boundary(b.len() - s) {
        s -= 1;
    }
    (
        Span::from_range(p..a.len() - s),
        new[p..b.len() - s].to_owned(),
    )
}

/// The new text of the edits file `text` without edit `id`: written
/// canonically when the file has no problems (`grm_edits::write`), else
/// with just that edit's element taken out (a rewrite would drop the
/// edits that have problems). `None` when there is no such edit.
pub(crate) fn without_edit(text: &str, id: u32) -> Option<(Span, String)> {
    let parsed = grm_edits::parse(text);
    if parsed.errors.is_empty() {
        let mut file = parsed.file;
        file.remove(id)?;
        return Some(minimal_edit(text, &grm_edits::write(&file)));
    }
    let span = parsed.file.get(id)?.span;
    let lay = layout(text);
    let at = lay
        .elements
        .iter()
        .position(|&(s, e)| s == span.start as usize && e == span.end as usize)?;
    remove_element(&lay, at)
}

impl Backend {
    /// Quick fixes on an edits file: on the diagnostic of an edit, the
    /// targets its last preview proposed for it, best first ("Retarget
    /// edit N to ..."), then "Delete edit N".
    pub(crate) async fn edits_code_actions(
        &self,
        params: CodeActionParams,
        path: PathBuf,
    ) -> Result<Option<CodeActionResponse>> {
        let uri = params.text_document.uri.clone();
        let open = self.shared.edits_source().open;
        let Ok(Some((_, text))) = read(&open, &path) else {
            return Ok(Some(Vec::new()));
        };
        // What the last previews made of the edits the diagnostics are on.
        let parsed = grm_edits::parse(&text);
        let reports: HashMap<u32, (grm_edits::Edit, EditOut)> = parsed
            .file
            .edits
            .iter()
            .filter_map(|e| Some((e.id, self.shared.edit_report(&path, e.id)?)))
            .collect();
        let shared = self.shared.clone();
        let actions = tokio::task::spawn_blocking(move || {
            let src = SourceFile::new("", &*text);
            let lay = layout(&text);
            let mut done = HashSet::new();
            let mut out = Vec::new();
            let action = |title: String, d: &Diagnostic, span: Span, new_text: String| {
                CodeActionOrCommand::CodeAction(CodeAction {
                    title,
                    kind: Some(CodeActionKind::QUICKFIX),
                    diagnostics: Some(vec![d.clone()]),
                    edit: Some(WorkspaceEdit {
                        changes: Some(HashMap::from([(
                            uri.clone(),
                            vec![TextEdit {
                                range: convert::range(&src, span),
                                new_text,
                            }],
                        )])),
                        ..WorkspaceEdit::default()
                    }),
                    ..CodeAction::default()
                })
            };
            for d in &params.context.diagnostics {
                let at = convert::offset(&src, d.range.start) as usize;
                let Some(el) = lay.elements.iter().position(|&(s, e)| s <= at && at < e) else {
                    continue;
                };
                if !done.insert(el) {
                    continue;
                }
                let (s, e) = lay.elements[el];
                let now = parsed
                    .file
                    .edits
                    .iter()
                    .find(|x| x.span == Span::from_range(s..e));
                let id = now.map(|x| x.id);
                // Retarget: only what the preview proposed for the edit as
                // it reads now.
                if let Some(now) = now
                    && let Some((seen, report)) = reports.get(&now.id)
                    && seen == now
                {
                    for c in &report.retarget {
                        let Some(target) = c.target() else {
                            continue;
                        };
                        let title = retarget_title(now.id, &target, c);
                        // A semantic candidate keeps how many parts it
                        // selects now (the edit's `selected`).
                        let selected = (matches!(target, Target::Semantic(_))
                            && !c.parts.is_empty())
                        .then_some(c.parts.len() as u32);
                        // A key candidate records the symbol of its part
                        // (the edit's `symbol`).
                        let symbol = c.symbol.clone();
                        if let Some((span, new_text)) =
                            retargeted(&text, now.id, target, selected, symbol)
                        {
                            out.push(action(title, d, span, new_text));
                        }
                    }
                }
                let edit = match id {
                    Some(id) => without_edit(&text, id),
                    None => remove_element(&lay, el),
                };
                let Some((span, new_text)) = edit else {
                    continue;
                };
                let title = match id {
                    Some(id) => format!("Delete edit {id}"),
                    None => "Delete this edit".to_owned(),
                };
                out.push(action(title, d, span, new_text));
            }
            // Bake: the semantic edit at the cursor, when the last preview
            // replayed it as it reads now.
            let wants_bake = params.context.only.as_ref().is_none_or(|only| {
                only.iter().any(|k| {
                    CodeActionKind::REFACTOR_REWRITE
                        .as_str()
                        .starts_with(k.as_str())
                })
            });
            let at = convert::offset(&src, params.range.start) as usize;
            let here = parsed
                .file
                .edits
                .iter()
                .find(|x| (x.span.start as usize) <= at && at < x.span.end as usize);
            if wants_bake
                && let Some(now) = here
                && matches!(now.target, Target::Semantic(_))
                && let Some((seen, report)) = reports.get(&now.id)
                && seen == now
                && report.replayed
            {
                out.push(bake_action(&shared, &path, &uri, &text, now));
            }
            out
        })
        .await
        .map_err(|e| failed(e.to_string()))?;
        Ok(Some(actions))
    }
}

/// "Bake edit N into the grammar": the grammar's rules changed
/// (`grm_grow::shape::bake`) and the edit deleted, one workspace edit over
/// both files; a disabled action with the reason when it cannot be baked
/// exactly.
fn bake_action(
    shared: &Shared,
    path: &Path,
    uri: &Uri,
    text: &str,
    edit: &grm_edits::Edit,
) -> CodeActionOrCommand {
    let title = format!("Bake edit {} into the grammar", edit.id);
    let made = (|| -> std::result::Result<(String, WorkspaceEdit), String> {
        let grammar = crate::edits::grammar_of(path).ok_or("no grammar beside the edits file")?;
        let fa = shared
            .analyze(&grammar)
            .ok_or_else(|| format!("{} cannot be read", grammar.display()))?;
        if fa.checked.has_errors() {
            return Err("the grammar has errors".to_owned());
        }
        let prog = &fa.checked.program;
        let sys = prog
            .system(&edit.system)
            .ok_or_else(|| format!("the grammar has no system `{}`", edit.system))?;
        let sys_src = fa.sources.get(sys.file);
        let sys_path = grm_sema::normalize(Path::new(&sys_src.path));
        if grm_edits::edits_path(&sys_path) != path {
            return Err("the system's rules are in another file".to_owned());
        }
        let values = prog.default_params();
        let lowered = grm_grow::shape::lower(prog, sys, &values).map_err(|e| format!("{e:?}"))?;
        let options = grm_grow::shape::ShapeOptions {
            threads: 1,
            ..grm_grow::shape::ShapeOptions::default()
        };
        let tree =
            grm_grow::shape::derive(&lowered, lowered.seed, &options).map_err(|e| e.to_string())?;
        let baked = grm_grow::shape::bake::bake(sys, &lowered, &tree, &sys_src.text, edit)?;
        let gsrc = SourceFile::new("", sys_src.text.as_str());
        let grammar_uri = shared
            .uris()
            .uri_of(&sys_path)
            .ok_or("the grammar has no URI")?;
        let (span, new_text) = without_edit(text, edit.id).ok_or("the edit is gone")?;
        let esrc = SourceFile::new("", text);
        let changes = HashMap::from([
            (
                grammar_uri,
                baked
                    .edits
                    .iter()
                    .map(|(s, t)| TextEdit {
                        range: convert::range(&gsrc, *s),
                        new_text: t.clone(),
                    })
                    .collect(),
            ),
            (
                uri.clone(),
                vec![TextEdit {
                    range: convert::range(&esrc, span),
                    new_text,
                }],
            ),
        ]);
        Ok((
            format!("{} : {} -> ...", baked.symbol, baked.condition),
            WorkspaceEdit {
                changes: Some(changes),
                ..WorkspaceEdit::default()
            },
        ))
    })();
    CodeActionOrCommand::CodeAction(match made {
        Ok((rule, edit)) => CodeAction {
            title: format!("{title} ({rule})"),
            kind: Some(CodeActionKind::REFACTOR_REWRITE),
            edit: Some(edit),
            ..CodeAction::default()
        },
        Err(reason) => CodeAction {
            title,
            kind: Some(CodeActionKind::REFACTOR_REWRITE),
            disabled: Some(CodeActionDisabled { reason }),
            ..CodeAction::default()
        },
    })
}

/// `Retarget edit 3 to (floor = 3) Window (same symbol and tags; 6 parts)`.
fn retarget_title(id: u32, target: &Target, c: &RetargetOut) -> String {
    let why =
        grm_grow::retarget::Reason::from_name(&c.reason).map_or(c.reason.as_str(), |r| r.words());
    let parts = if c.parts.len() == 1 {
        String::new()
    } else {
        format!("; {} parts", c.parts.len())
    };
    format!("Retarget edit {id} to {} ({why}{parts})", target.text())
}

/// The new text of the edits file `text` with edit `id`'s target
/// replaced: written canonically when the file has no problems, else just
/// that edit's element written again (a rewrite would drop the edits that
/// have problems). `selected`: the new target's count of parts, for a
/// semantic one (`Edit::selected`); `symbol`: the symbol of the part a
/// new key target names (`Edit::symbol`); the old target's are dropped.
/// `None` when there is no such edit, or when the new key's symbol is
/// not the one another edit of that key records ([`symbol_clash`]: the
/// file would refuse the edit, R0911).
fn retargeted(
    text: &str,
    id: u32,
    target: Target,
    selected: Option<u32>,
    symbol: Option<String>,
) -> Option<(Span, String)> {
    let parsed = grm_edits::parse(text);
    let selected = selected.filter(|_| matches!(target, Target::Semantic(_)));
    let symbol = symbol.filter(|_| matches!(target, Target::Key(_)));
    if parsed.errors.is_empty() {
        let mut file = parsed.file;
        file.retarget(id, target)?;
        let e = file.edits.iter_mut().find(|e| e.id == id)?;
        e.selected = selected;
        e.symbol = symbol;
        let e = file.get(id)?;
        if symbol_clash(&file.edits, e).is_some() {
            return None;
        }
        return Some(minimal_edit(text, &grm_edits::write(&file)));
    }
    let mut e = parsed.file.get(id)?.clone();
    let span = e.span;
    e.target = target;
    e.selected = selected;
    e.symbol = symbol;
    if symbol_clash(&parsed.file.edits, &e).is_some() {
        return None;
    }
    Some((span, grm_edits::write_edit(&e)))
}

/// Another edit among `edits` of the key `edit` targets, in its system
/// and parcel, that records another symbol than the one `edit` records:
/// with both, the file refuses one of them (R0911: a key names one part,
/// of one symbol). `None` when there is none, or `edit` records no
/// symbol or targets no key.
pub(crate) fn symbol_clash<'a>(
    edits: &'a [grm_edits::Edit],
    edit: &grm_edits::Edit,
) -> Option<&'a grm_edits::Edit> {
    let (Target::Key(k), Some(sym)) = (&edit.target, &edit.symbol) else {
        return None;
    };
    edits.iter().find(|o| {
        o.id != edit.id
            && o.system == edit.system
            && o.parcel == edit.parcel
            && matches!(o.target, Target::Key(j) if j == *k)
            && o.symbol.as_ref().is_some_and(|s| s != sym)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_semantic_retarget_records_its_count_and_an_exact_one_drops_it() {
        let text = grm_edits::write(&{
            let mut f = grm_edits::EditsFile::default();
            f.add("S", Target::Key(1), grm_edits::Op::Remove);
            f
        });
        let q: Target = Target::Semantic("(floor = 2) Window".parse().unwrap());
        let (span, new) = retargeted(&text, 1, q, Some(3), Some("Window".into())).unwrap();
        let mut t = text.clone();
        t.replace_range(span.range(), &new);
        let f = grm_edits::parse(&t).file;
        assert_eq!(f.version, 2, "{t}");
        assert_eq!(f.edits[0].selected, Some(3), "{t}");
        let exact = Target::Exact("{Lot, #1, A}".parse().unwrap());
        let (span, new) = retargeted(&t, 1, exact, Some(3), None).unwrap();
        let mut u = t.clone();
        u.replace_range(span.range(), &new);
        assert_eq!(grm_edits::parse(&u).file.edits[0].selected, None, "{u}");
    }

    #[test]
    fn a_key_retarget_records_its_symbol_and_another_target_drops_it() {
        let text = grm_edits::write(&{
            let mut f = grm_edits::EditsFile::default();
            f.add(
                "S",
                Target::Semantic("(floor = 1) Door".parse().unwrap()),
                grm_edits::Op::Remove,
            );
            f.add("S", Target::Key(7), grm_edits::Op::Remove);
            f
        });
        let apply = |t: &str, (span, new): (Span, String)| {
            let mut t = t.to_owned();
            t.replace_range(span.range(), &new);
            t
        };
        // A key with its part's symbol (a count given for it is dropped).
        let t = apply(
            &text,
            retargeted(&text, 1, Target::Key(9), Some(2), Some("Window".into())).unwrap(),
        );
        let f = grm_edits::parse(&t);
        assert!(f.errors.is_empty(), "{t}");
        assert_eq!(f.file.version, 3, "{t}");
        let e = f.file.get(1).unwrap();
        assert_eq!((e.symbol.as_deref(), e.selected), (Some("Window"), None));
        assert!(t.contains("\"symbol\": \"Window\""), "{t}");
        // A semantic target records none.
        let q = Target::Semantic("(floor = 2) Window".parse().unwrap());
        let u = apply(
            &t,
            retargeted(&t, 1, q, Some(2), Some("Window".into())).unwrap(),
        );
        assert_eq!(
            grm_edits::parse(&u).file.get(1).unwrap().symbol,
            None,
            "{u}"
        );
        // Edit 2's key with another symbol than edit 1 records for it: the
        // file would refuse it, so it is not offered; with the same, it is.
        assert!(retargeted(&t, 2, Target::Key(9), None, Some("Wall".into())).is_none());
        let v = apply(
            &t,
            retargeted(&t, 2, Target::Key(9), None, Some("Window".into())).unwrap(),
        );
        assert!(grm_edits::parse(&v).errors.is_empty(), "{v}");
        // With a problem in the file, the element alone gets the symbol.
        let bad = text.replacen("\"op\": \"remove\"", "\"op\": \"paint\"", 1);
        let w = apply(
            &bad,
            retargeted(&bad, 2, Target::Key(9), None, Some("Window".into())).unwrap(),
        );
        let p = grm_edits::parse(&w);
        assert_eq!(p.errors.len(), 1, "{w}");
        assert_eq!(
            p.file.get(2).unwrap().symbol.as_deref(),
            Some("Window"),
            "{w}"
        );
    }

    #[test]
    fn minimal_edits_keep_the_common_ends() {
        for (a, b) in [
            ("", "abc"),
            ("abc", ""),
            ("abc", "abc"),
            ("abXc", "abc"),
            ("aé", "aè"),
            ("x\u{1F333}y", "x\u{1F332}y"),
            ("aaa", "aaaa"),
        ] {
            let (span, text) = minimal_edit(a, b);
            let mut s = a.to_string();
            s.replace_range(span.range(), &text);
            assert_eq!(s, b, "{a:?} -> {b:?}");
        }
        assert_eq!(minimal_edit("abXc", "abc").0, Span::new(2, 3));
    }

    fn file_of(n: u32) -> String {
        let mut f = grm_edits::EditsFile::default();
        for i in 0..n {
            f.add(
                "S",
                grm_edits::Target::Key(i),
                grm_edits::Op::Force { alternative: 1 },
            );
        }
        grm_edits::write(&f)
    }

    #[test]
    fn layout_finds_each_element_and_removal_leaves_json() {
        for n in 1..4 {
            let text = file_of(n);
            let parsed = grm_edits::parse(&text);
            let lay = layout(&text);
            let spans: Vec<(usize, usize)> = parsed
                .file
                .edits
                .iter()
                .map(|e| (e.span.start as usize, e.span.end as usize))
                .collect();
            assert_eq!(lay.elements, spans);
            for at in 0..n as usize {
                let (span, t) = remove_element(&lay, at).unwrap();
                let mut s = text.clone();
                s.replace_range(span.range(), &t);
                let p = grm_edits::parse(&s);
                assert!(p.errors.is_empty(), "{s}");
                assert_eq!(p.file.edits.len(), n as usize - 1);
                assert!(p.file.get(at as u32 + 1).is_none());
            }
        }
        // A broken element is found too (strings with braces, escapes).
        let text = r#"{ "version": 1, "edits": [ { "id": "x{\"", "op": [1, {"a": 2}] }, 7 ] }"#;
        let lay = layout(text);
        assert_eq!(lay.elements.len(), 2);
        assert_eq!(&text[lay.elements[1].0..lay.elements[1].1], "7");
        assert!(text[lay.elements[0].0..lay.elements[0].1].ends_with("}] }"));
        assert_eq!(layout("not json").elements, []);
    }

    #[test]
    fn removing_an_edit_rewrites_or_cuts() {
        let text = file_of(3);
        let (span, t) = without_edit(&text, 2).unwrap();
        let mut s = text.clone();
        s.replace_range(span.range(), &t);
        let mut f = grm_edits::parse(&text).file;
        f.remove(2);
        assert_eq!(s, grm_edits::write(&f), "canonical");
        // With a problem in the file, the edit's element alone is cut out.
        let bad = text.replacen("\"op\": \"force\"", "\"op\": \"forse\"", 1);
        let (span, t) = without_edit(&bad, 3).unwrap();
        let mut s = bad.clone();
        s.replace_range(span.range(), &t);
        let p = grm_edits::parse(&s);
        assert_eq!(p.errors.len(), 1, "the broken edit stays");
        assert_eq!(p.file.edits.len(), 1);
        assert!(without_edit(&bad, 9).is_none());
    }
}

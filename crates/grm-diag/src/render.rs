//! Rendering diagnostics: human text through ariadne (spans converted to
//! character offsets, so carets stay right on non-ASCII text) and JSON for
//! tools.

use crate::{Diagnostic, Severity, SourceMap, Span};
use ariadne::{Config, IndexType, Label as ALabel, Report, ReportKind};
use serde::Serialize;

/// The span clamped to the text and to char boundaries, as a range of
/// character (Unicode scalar value) offsets. ariadne is given character
/// offsets: in byte mode it places the header of a label in a file other
/// than the primary one by a character offset read as a byte offset, which
/// gives a wrong column or panics on a non-ASCII line.
fn clamp(span: Span, text: &str) -> std::ops::Range<usize> {
    let len = text.len();
    let mut s = (span.start as usize).min(len);
    let mut e = (span.end as usize).min(len).max(s);
    while !text.is_char_boundary(s) {
        s -= 1;
    }
    while !text.is_char_boundary(e) {
        e += 1;
    }
    let start = text[..s].chars().count();
    start..start + text[s..e].chars().count()
}

/// The text as ariadne gets it. ariadne breaks lines where grm does (at
/// `\n`, `\r\n` as one break, and a lone `\r`), and also at a vertical
/// tab, form feed, U+0085, U+2028 and U+2029, which are no line breaks for
/// grm (nor for the JSON and LSP positions). U+2028 and U+2029 are shown
/// as a space; every other control character (see [`shown_char`]) as a
/// visible stand-in, so a terminal never acts on one. Each character stays
/// one character, which keeps every character offset and the line numbers.
fn lines_at_newlines(text: &str) -> String {
    text.chars()
        .map(|c| match c {
            '\u{2028}' | '\u{2029}' => ' ',
            c => shown_char(c),
        })
        .collect()
}

/// Whether `c` is a bidirectional formatting character (U+202A to U+202E,
/// U+2066 to U+2069): one in a comment or string can make a line read
/// differently from how it is parsed ("Trojan Source", CVE-2021-42574).
/// The lexer warns of each (W0017); the human rendering never prints one.
pub fn is_bidi_control(c: char) -> bool {
    matches!(c, '\u{202A}'..='\u{202E}' | '\u{2066}'..='\u{2069}')
}

/// Whether the human rendering must not print `c` as it is: a C0 or C1
/// control character other than tab and the line breaks (an escape
/// sequence in a source line, `ESC ] 0;title BEL`, retitled the terminal
/// or worse), DEL, or a bidirectional formatting character.
fn is_hidden(c: char) -> bool {
    (c.is_control() && !matches!(c, '\t' | '\n' | '\r')) || is_bidi_control(c)
}

/// A source character as the human rendering shows it: a C0 control
/// character as its Unicode control picture (ESC as `␛`), DEL as `␡`, a
/// C1 control or bidirectional formatting character as U+FFFD; any other
/// character as it is. One character for one, so the carets stay right.
fn shown_char(c: char) -> char {
    match c {
        '\0'..='\x1f' if is_hidden(c) => char::from_u32(0x2400 + c as u32).unwrap_or('\u{FFFD}'),
        '\x7f' => '\u{2421}',
        c if is_hidden(c) => '\u{FFFD}',
        c => c,
    }
}

/// Message text (a message, label, note, help or file name) as the human
/// rendering prints it: each character of [`is_hidden`] but a line break
/// written as a Rust-style escape, `\u{1b}`.
fn escaped(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(|c| is_hidden(c) || c == '\r') {
        return text.into();
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if is_hidden(c) || c == '\r' {
            out += &format!("\\u{{{:x}}}", c as u32);
        } else {
            out.push(c);
        }
    }
    out.into()
}

/// Render one diagnostic as text, with colour if `color` is set (for
/// many, a [`HumanRenderer`] prepares each file's text once).
pub fn render_human(d: &Diagnostic, sources: &SourceMap, color: bool) -> String {
    HumanRenderer::new(sources, color).render(d)
}

/// The fetch function of the renderer's cache.
type Fetch<'a> = Box<dyn FnMut(&String) -> Result<String, String> + 'a>;

/// Renders diagnostics of one [`SourceMap`] as text: each file's text is
/// prepared for ariadne once, the first time a label needs it, and not
/// again for every diagnostic (rendering was quadratic: ten thousand
/// diagnostics of a 10 KB file took 51 s).
pub struct HumanRenderer<'a> {
    sources: &'a SourceMap,
    color: bool,
    cache: ariadne::FnCache<String, Fetch<'a>, String>,
}

impl std::fmt::Debug for HumanRenderer<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HumanRenderer")
            .field("files", &self.sources.iter().count())
            .field("color", &self.color)
            .finish_non_exhaustive()
    }
}

impl<'a> HumanRenderer<'a> {
    pub fn new(sources: &'a SourceMap, color: bool) -> HumanRenderer<'a> {
        let fetch: Fetch<'a> = Box::new(move |path: &String| {
            sources
                .iter()
                .find(|(_, f)| escaped(&f.path) == path.as_str())
                .map(|(_, f)| lines_at_newlines(&f.text))
                .ok_or_else(|| format!("no source file {path}"))
        });
        HumanRenderer {
            sources,
            color,
            cache: ariadne::FnCache::new(fetch),
        }
    }

    /// One diagnostic as text.
    pub fn render(&mut self, d: &Diagnostic) -> String {
        if let Some((file, line, len)) = long_line(d, self.sources) {
            return render_without_source(d, self.sources, file, line, len);
        }
        let (sources, color) = (self.sources, self.color);
        let kind = match d.severity {
            Severity::Error => ReportKind::Error,
            Severity::Warning => ReportKind::Warning,
        };
        let primary = d.primary();
        let pfile = sources.get(primary.file);
        let id = |f: crate::FileId| escaped(&sources.get(f).path).into_owned();
        let mut report = Report::build(kind, (id(primary.file), clamp(primary.span, &pfile.text)))
            .with_config(
                Config::default()
                    .with_index_type(IndexType::Char)
                    .with_color(color),
            )
            .with_code(d.code.as_str())
            .with_message(escaped(&d.message));
        // ariadne starts a new source group (with a header repeating the
        // primary's line:col) whenever a label comes before the previous one in
        // the file; ordered by file (the primary's first) and position, each
        // file is one group whose lines read top to bottom (labels on one line
        // keep their order).
        let line_of = |l: &crate::Label| sources.get(l.file).line_of(l.span.start);
        let mut by_place: Vec<usize> = (0..d.labels.len()).collect();
        by_place.sort_by_cached_key(|&i| {
            let l = &d.labels[i];
            (l.file != primary.file, l.file.0, line_of(l), i)
        });
        let mut order = vec![0; d.labels.len()];
        for (rank, &i) in by_place.iter().enumerate() {
            order[i] = rank;
        }
        for (l, &order) in d.labels.iter().zip(&order) {
            let text = &sources.get(l.file).text;
            let mut label = ALabel::new((id(l.file), clamp(l.span, text))).with_order(order as i32);
            if !l.message.is_empty() {
                label = label.with_message(escaped(&l.message));
            }
            if l.primary {
                label = label.with_priority(1);
            }
            report = report.with_label(label);
        }
        for n in &d.notes {
            report = report.with_note(escaped(n));
        }
        if let Some(h) = &d.help {
            report = report.with_help(escaped(h));
        }
        let mut out = Vec::new();
        // Writing into a Vec<u8> cannot fail for I/O reasons; if ariadne reports
        // an error anyway, fall back to the plain one-line form.
        if report.finish().write(&mut self.cache, &mut out).is_err() {
            return render_plain(d, sources);
        }
        String::from_utf8_lossy(&out).into_owned()
    }
}

/// Source lines longer than this (in bytes) are not shown under a
/// diagnostic: ariadne prints a label's whole line and pads its caret line
/// to the column, so two thousand diagnostics on one 11,000-character line
/// (a generated grammar) printed 43 MB.
pub const MAX_SHOWN_LINE: u32 = 1000;

/// The first line a label of `d` covers that is longer than
/// [`MAX_SHOWN_LINE`]: its file's path, zero-based number and length in
/// characters.
fn long_line<'s>(d: &Diagnostic, sources: &'s SourceMap) -> Option<(&'s str, u32, usize)> {
    d.labels.iter().find_map(|l| {
        let f = sources.get(l.file);
        let (first, last) = (f.line_of(l.span.start), f.line_of(l.span.end));
        // A label over many lines shows its first and last lines.
        [first, last].into_iter().find_map(|line| {
            let (s, e) = (f.line_start(line)?, f.line_end(line)?);
            (e.saturating_sub(s) > MAX_SHOWN_LINE).then(|| {
                let len = f
                    .text
                    .get(s as usize..e as usize)
                    .map_or(0, |t| t.chars().count());
                (f.path.as_str(), line, len)
            })
        })
    })
}

/// A diagnostic whose source line is too long to show: its header, each
/// label's place and message, its notes and help, in ariadne's frame.
fn render_without_source(
    d: &Diagnostic,
    sources: &SourceMap,
    path: &str,
    line: u32,
    len: usize,
) -> String {
    let kind = match d.severity {
        Severity::Error => "Error",
        Severity::Warning => "Warning",
    };
    let at = |l: &crate::Label| {
        let f = sources.get(l.file);
        let (line, col) = f.line_col(l.span.start);
        format!("{}:{}:{}", escaped(&f.path), line + 1, col + 1)
    };
    let path = escaped(path);
    let mut out = format!("[{}] {kind}: {}\n", d.code, escaped(&d.message));
    out += &format!("   ╭─[ {} ]\n", at(d.primary()));
    out += &format!(
        "   │ ({path} line {} has {len} characters: not shown)\n",
        line + 1
    );
    for l in &d.labels {
        if l.message.is_empty() {
            continue;
        }
        match l.primary {
            true => out += &format!("   │ {}\n", escaped(&l.message)),
            false => out += &format!("   │ {}: {}\n", at(l), escaped(&l.message)),
        }
    }
    for n in &d.notes {
        out += &format!("   │ Note: {}\n", escaped(n));
    }
    if let Some(h) = &d.help {
        out += &format!("   │ Help: {}\n", escaped(h));
    }
    out += "───╯\n";
    out
}

/// One line per diagnostic: `path:line:col: error[E0101]: message`.
pub fn render_plain(d: &Diagnostic, sources: &SourceMap) -> String {
    let p = d.primary();
    let f = sources.get(p.file);
    let (line, col) = f.line_col(p.span.start);
    let sev = match d.severity {
        Severity::Error => "error",
        Severity::Warning => "warning",
    };
    format!(
        "{}:{}:{}: {}[{}]: {}",
        escaped(&f.path),
        line + 1,
        col + 1,
        sev,
        d.code,
        escaped(&d.message)
    )
}

#[derive(Serialize)]
struct JsonPos {
    line: u32,
    column: u32,
}

#[derive(Serialize)]
struct JsonLabel<'a> {
    file: &'a str,
    start: u32,
    end: u32,
    start_pos: JsonPos,
    end_pos: JsonPos,
    message: &'a str,
    primary: bool,
}

#[derive(Serialize)]
struct JsonDiag<'a> {
    code: &'a str,
    severity: Severity,
    message: &'a str,
    file: &'a str,
    labels: Vec<JsonLabel<'a>>,
    notes: &'a [String],
    help: Option<&'a str>,
}

fn json_value<'a>(d: &'a Diagnostic, sources: &'a SourceMap) -> JsonDiag<'a> {
    let pos = |file: &crate::SourceFile, off: u32| {
        let (l, c) = file.line_col(off);
        JsonPos {
            line: l + 1,
            column: c + 1,
        }
    };
    JsonDiag {
        code: d.code.as_str(),
        severity: d.severity,
        message: &d.message,
        file: &sources.get(d.primary().file).path,
        labels: d
            .labels
            .iter()
            .map(|l| {
                let f = sources.get(l.file);
                JsonLabel {
                    file: &f.path,
                    start: l.span.start,
                    end: l.span.end,
                    start_pos: pos(f, l.span.start),
                    end_pos: pos(f, l.span.end),
                    message: &l.message,
                    primary: l.primary,
                }
            })
            .collect(),
        notes: &d.notes,
        help: d.help.as_deref(),
    }
}

/// One diagnostic as a JSON object (a single line).
pub fn render_json(d: &Diagnostic, sources: &SourceMap) -> String {
    // Serializing plain structs of strings and integers cannot fail.
    serde_json::to_string(&json_value(d, sources)).unwrap_or_default()
}

/// All diagnostics as one JSON array.
pub fn to_json(diags: &[Diagnostic], sources: &SourceMap) -> String {
    let v: Vec<_> = diags.iter().map(|d| json_value(d, sources)).collect();
    serde_json::to_string_pretty(&v).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Code, Diagnostic, SourceMap};

    #[test]
    fn renders_non_ascii_carets_and_json() {
        let mut sm = SourceMap::new();
        let text = "const é = ü + 1;\n";
        let f = sm.add("t.grm", text);
        let start = text.find('ü').unwrap() as u32;
        let d = Diagnostic::new(
            Code::UnknownName,
            "unknown name `ü`",
            f,
            Span::new(start, start + 2),
            "not found",
        )
        .with_help("define it");
        let out = render_human(&d, &sm, false);
        assert!(out.contains("E0101"), "{out}");
        assert!(out.contains("not found"), "{out}");
        let j = render_json(&d, &sm);
        assert!(j.contains("\"column\":11"), "{j}");
        assert_eq!(
            render_plain(&d, &sm),
            "t.grm:1:11: error[E0101]: unknown name `ü`"
        );
    }

    /// A label on a line too long to show gives its place, messages,
    /// notes and help, without the line; a short line is still shown.
    #[test]
    fn a_line_too_long_is_not_shown() {
        let mut sm = SourceMap::new();
        let names: Vec<String> = (0..400).map(|i| format!("I{i}")).collect();
        let text = format!("system A {{ ignore {}; }}\nconst é = q;\n", names.join(" "));
        let f = sm.add("long.grm", text.as_str());
        let at = text.find("I399").unwrap() as u32;
        let d = Diagnostic::new(
            Code::UnknownName,
            "`I399` never occurs",
            f,
            Span::new(at, at + 4),
            "unknown symbol",
        )
        .with_note("a note")
        .with_help("remove it");
        let out = render_human(&d, &sm, false);
        let col = text[..at as usize].chars().count() + 1;
        assert!(
            out.starts_with("[E0101] Error: `I399` never occurs\n"),
            "{out}"
        );
        assert!(out.contains(&format!("long.grm:1:{col} ]")), "{out}");
        assert!(out.contains("line 1 has"), "{out}");
        assert!(
            out.contains("unknown symbol")
                && out.contains("Note: a note")
                && out.contains("Help: remove it"),
            "{out}"
        );
        assert!(out.len() < 400, "{} bytes: {out}", out.len());
        // The same diagnostic on the short line shows it.
        let q = text.rfind('q').unwrap() as u32;
        let d = Diagnostic::new(
            Code::UnknownName,
            "unknown `q`",
            f,
            Span::new(q, q + 1),
            "here",
        );
        let out = render_human(&d, &sm, false);
        assert!(out.contains("const é = q;"), "{out}");
    }

    /// A renderer that keeps each file's prepared text renders every
    /// diagnostic as rendering it alone does, across files.
    #[test]
    fn a_renderer_renders_as_one_at_a_time() {
        let mut sm = SourceMap::new();
        let a = sm.add("a.grm", "const x = y;\nconst z = w;\n");
        let b = sm.add("b.grm", "// é\nconst q = r;\n");
        let ds = [
            Diagnostic::new(
                Code::UnknownName,
                "unknown `y`",
                a,
                Span::new(10, 11),
                "here",
            ),
            Diagnostic::new(
                Code::UnknownName,
                "unknown `r`",
                b,
                Span::new(16, 17),
                "here",
            )
            .with_label(a, Span::new(23, 24), "and here"),
            Diagnostic::new(
                Code::UnknownName,
                "unknown `w`",
                a,
                Span::new(23, 24),
                "here",
            ),
        ];
        let mut r = HumanRenderer::new(&sm, false);
        for d in &ds {
            let once = render_human(d, &sm, false);
            assert!(once.contains(&d.message), "{once}");
            assert_eq!(r.render(d), once);
        }
    }

    #[test]
    fn label_in_another_non_ascii_file() {
        // The secondary label's file has non-ASCII text before the label:
        // ariadne's byte mode panicked here (or showed a wrong column).
        let mut sm = SourceMap::new();
        let lib = sm.add("lib.grm", "const size = 1;\n");
        let main_text = format!("// {}\nconst size = 2;\n", "é".repeat(40));
        let main = sm.add("main.grm", main_text.clone());
        let at = main_text.find("size").unwrap() as u32;
        let d = Diagnostic::new(
            Code::DuplicateDefinition,
            "`size` is defined more than once",
            lib,
            Span::new(6, 10),
            "defined again here",
        )
        .with_label(main, Span::new(at, at + 4), "first defined here");
        let out = render_human(&d, &sm, false);
        assert!(out.contains("lib.grm:1:7"), "{out}");
        assert!(out.contains("main.grm:2:7"), "{out}");
    }

    #[test]
    fn labels_of_one_file_are_one_group_in_line_order() {
        // A secondary label above the primary, with `\n`, `\r\n` and lone
        // `\r` line ends: one header, the primary's, and the lines top to
        // bottom (a label above the previous one used to open a second
        // group whose header repeated the primary's line:col).
        for nl in ["\n", "\r\n", "\r"] {
            let text = ["system P {", "  axiom F X;", "  G -> F;", "}", ""].join(nl);
            let mut sm = SourceMap::new();
            let f = sm.add("t.grm", text.as_str());
            let g = text.find('G').unwrap() as u32;
            let x = text.find('X').unwrap() as u32;
            let d = Diagnostic::new(
                Code::UnreachableProduction,
                "m",
                f,
                Span::new(g, g + 1),
                "primary",
            )
            .with_label(f, Span::new(x, x + 1), "secondary");
            let out = render_human(&d, &sm, false);
            assert_eq!(out.matches("t.grm:").count(), 1, "{nl:?}\n{out}");
            assert!(out.contains("t.grm:3:3"), "{out}");
            let (sec, pri) = (out.find("secondary").unwrap(), out.find("primary").unwrap());
            assert!(sec < pri, "{out}");
        }
    }

    #[test]
    fn line_numbers_count_only_line_breaks() {
        // A form feed or U+2028 is no line break for grm, a lone `\r` is:
        // the header agrees with `render_plain` (and the JSON and LSP
        // positions).
        let mut sm = SourceMap::new();
        let text = "// a\x0c b\u{2028} c\r d\nconst x = y;\n";
        let f = sm.add("t.grm", text);
        let at = text.find('y').unwrap() as u32;
        let d = Diagnostic::new(
            Code::UnknownName,
            "unknown",
            f,
            Span::new(at, at + 1),
            "here",
        );
        assert_eq!(render_plain(&d, &sm), "t.grm:3:11: error[E0101]: unknown");
        let out = render_human(&d, &sm, false);
        assert!(out.contains("t.grm:3:11"), "{out}");
    }

    #[test]
    fn lone_carriage_returns_and_crlf_in_every_rendering() {
        // The same program with old-Mac, Windows and mixed line endings:
        // every rendering puts `y` on line 3, column 11.
        for nl in ["\r", "\r\n", "\n", "mixed"] {
            let text = match nl {
                "mixed" => "// a\r\n// b\rconst x = y;\n".to_string(),
                nl => format!("// a{nl}// b{nl}const x = y;{nl}"),
            };
            let mut sm = SourceMap::new();
            let f = sm.add("t.grm", text.as_str());
            let at = text.find('y').unwrap() as u32;
            let d = Diagnostic::new(
                Code::UnknownName,
                "unknown",
                f,
                Span::new(at, at + 1),
                "here",
            );
            assert_eq!(
                render_plain(&d, &sm),
                "t.grm:3:11: error[E0101]: unknown",
                "{nl:?}"
            );
            let out = render_human(&d, &sm, false);
            assert!(out.contains("t.grm:3:11"), "{nl:?}: {out}");
            // The source line is shown without its line break.
            assert!(out.contains("const x = y;\n"), "{nl:?}: {out}");
            assert!(!out.contains('\r'), "{nl:?}: {out}");
            let j = render_json(&d, &sm);
            assert!(
                j.contains("\"start_pos\":{\"line\":3,\"column\":11}"),
                "{nl:?}: {j}"
            );
        }
    }

    /// A terminal escape sequence or any other control character in a
    /// source line, a message or a file name is never printed raw: the
    /// source shows control pictures (carets still under the right
    /// characters), the messages `\u{..}` escapes. `ESC ] 0;title BEL`
    /// retitled the terminal that ran `grmc check`.
    #[test]
    fn control_characters_are_never_printed_raw() {
        let text = "// \x1b]0;pwned\x07 \u{9b}2J \x7f \u{202e}x\u{2066}\nconst x = y;\n";
        let mut sm = SourceMap::new();
        let f = sm.add("t\x1b[31m.grm", text);
        let at = text.find('y').unwrap() as u32;
        let esc = text.find('\x1b').unwrap() as u32;
        let d = Diagnostic::new(
            Code::UnknownName,
            "unknown `\x1b[2J`",
            f,
            Span::new(at, at + 1),
            "here \x07",
        )
        .with_label(f, Span::new(esc, esc + 1), "escape \u{202e}")
        .with_note("a note \x1b")
        .with_help("help \u{9b}");
        let raw = |s: &str| {
            s.chars()
                .find(|&c| (c.is_control() && c != '\n') || crate::is_bidi_control(c))
        };
        for color in [false, true] {
            let out = render_human(&d, &sm, color);
            // With colour, ariadne's own SGR sequences are the only escapes.
            let stripped = out.replace("\x1b[0m", "");
            let stripped: String = if color {
                let mut s = String::new();
                let mut it = stripped.chars().peekable();
                while let Some(c) = it.next() {
                    if c == '\x1b' && it.peek() == Some(&'[') {
                        for c in it.by_ref() {
                            if c == 'm' {
                                break;
                            }
                        }
                    } else {
                        s.push(c);
                    }
                }
                s
            } else {
                stripped
            };
            assert_eq!(raw(&stripped), None, "{out:?}");
            assert!(
                stripped.contains("// ␛]0;pwned␇ \u{FFFD}2J ␡ \u{FFFD}x\u{FFFD}"),
                "{out}"
            );
            assert!(stripped.contains("t\\u{1b}[31m.grm:2:11"), "{out}");
            for m in [
                "unknown `\\u{1b}[2J`",
                "here \\u{7}",
                "escape \\u{202e}",
                "a note \\u{1b}",
                "help \\u{9b}",
            ] {
                assert!(stripped.contains(m), "{m}: {out}");
            }
        }
        assert_eq!(
            render_plain(&d, &sm),
            "t\\u{1b}[31m.grm:2:11: error[E0101]: unknown `\\u{1b}[2J`"
        );
        // A line too long to show: the same escapes.
        let long = format!("// \x1b]0;t\x07{}\nconst x = y;\n", "a".repeat(2000));
        let mut sm = SourceMap::new();
        let f = sm.add("l.grm", long.as_str());
        let d = Diagnostic::new(Code::UnknownName, "m \x1b", f, Span::new(3, 4), "l \x1b");
        let out = render_human(&d, &sm, false);
        assert!(out.contains("line 1 has"), "{out}");
        assert_eq!(raw(&out), None, "{out:?}");
    }

    #[test]
    fn out_of_range_spans_do_not_panic() {
        let mut sm = SourceMap::new();
        let f = sm.add("t.grm", "ab");
        let d = Diagnostic::new(Code::UnexpectedEof, "eof", f, Span::new(10, 20), "here");
        let _ = render_human(&d, &sm, false);
        let _ = render_json(&d, &sm);
    }

    #[test]
    fn utf16_columns() {
        let sf = crate::SourceFile::new("x", "a𝄞b\nc");
        // 'b' is at byte 5, UTF-16 column 3
        assert_eq!(sf.line_col_utf16(5), (0, 3));
        assert_eq!(sf.offset_of_utf16(0, 3), 5);
        assert_eq!(sf.offset_of_utf16(1, 0), 7);
    }
}

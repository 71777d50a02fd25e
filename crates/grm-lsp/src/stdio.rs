//! The stdio transport's guard: what reaches the server is well framed
//! and well formed, and a bad message is answered without ending the
//! session.
//!
//! `tower-lsp-server` reads stdin through a codec that stops the session at
//! the first message it cannot decode (a JSON syntax error, a `jsonrpc`
//! field other than `"2.0"`, an `id` of the wrong type, a header it does
//! not know such as `Content-Type`, a bad `Content-Length`): the server
//! answered a Parse error and exited. `crate::run_stdio` puts this module between the
//! process's stdio and the server:
//!
//! - [`Deframer`] splits the byte stream into message bodies the way the
//!   LSP base protocol frames them, tolerantly: header names are
//!   case-insensitive, lines may end in `\n` alone, headers other than
//!   `Content-Length` are ignored, and after garbage (a body without
//!   headers, a bad length) it resynchronises on the next
//!   `Content-Length:` header, reporting the garbage once.
//! - [`check`] accepts a body only if it is a JSON-RPC 2.0 request,
//!   notification or response; a lone UTF-16 surrogate escape (which
//!   JavaScript's `JSON.stringify` writes for a string holding half a
//!   surrogate pair, e.g. a document cut inside an emoji) becomes U+FFFD,
//!   one UTF-16 unit for one, so positions in later edits still agree.
//!   Anything else is answered with a Parse error (-32700) or an Invalid
//!   Request (-32600) and dropped.
//! - The server's own output is deframed the same way so that those
//!   answers are written between its messages, never inside one.

use serde_json::{Value, json};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};

/// The largest body accepted (a document's full text travels in one);
/// a longer one is skipped and answered with a Parse error.
pub const MAX_BODY: usize = 256 << 20;

/// What the deframer found.
#[derive(Debug, PartialEq, Eq)]
pub enum Event {
    /// A message body, as framed.
    Body(Vec<u8>),
    /// Bytes that were not a message, and why.
    Bad(String),
}

#[derive(Debug)]
enum State {
    Headers {
        length: Option<usize>,
        /// Why this message will be dropped, and how many body bytes to
        /// skip then (a length that parsed but is over [`MAX_BODY`]).
        bad: Option<(String, usize)>,
        /// A header line was seen (a blank line then ends the headers).
        seen: bool,
    },
    Body(usize),
    Skip(usize),
}

impl State {
    fn headers() -> State {
        State::Headers {
            length: None,
            bad: None,
            seen: false,
        }
    }
}

/// Splits a byte stream into LSP message bodies (see the module doc).
#[derive(Debug)]
pub struct Deframer {
    /// The largest body read ([`MAX_BODY`]).
    max: usize,
    buf: Vec<u8>,
    /// Where unread bytes start in `buf`.
    at: usize,
    state: State,
    /// In a run of lines that are not headers (reported once).
    garbage: bool,
}

impl Default for Deframer {
    fn default() -> Self {
        Deframer {
            max: MAX_BODY,
            buf: Vec::new(),
            at: 0,
            state: State::headers(),
            garbage: false,
        }
    }
}

const CONTENT_LENGTH: &[u8] = b"content-length:";

fn find_ci(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len())
        .position(|w| w.eq_ignore_ascii_case(needle))
}

impl Deframer {
    /// A deframer that reads bodies of at most `max` bytes.
    pub fn with_max(max: usize) -> Deframer {
        Deframer {
            max,
            ..Deframer::default()
        }
    }

    pub fn push(&mut self, bytes: &[u8]) {
        if self.at > 0 && self.at == self.buf.len() {
            self.buf.clear();
            self.at = 0;
        } else if self.at > (1 << 16) && self.at * 2 > self.buf.len() {
            self.buf.drain(..self.at);
            self.at = 0;
        }
        self.buf.extend_from_slice(bytes);
    }

    /// The next complete event, or `None` until more bytes come.
    pub fn next_event(&mut self) -> Option<Event> {
        loop {
            let rest = &self.buf[self.at..];
            match &mut self.state {
                State::Body(n) => {
                    let n = *n;
                    if rest.len() < n {
                        return None;
                    }
                    let body = rest[..n].to_vec();
                    self.at += n;
                    self.state = State::headers();
                    return Some(Event::Body(body));
                }
                State::Skip(n) => {
                    let k = (*n).min(rest.len());
                    self.at += k;
                    *n -= k;
                    if *n > 0 {
                        return None;
                    }
                    self.state = State::headers();
                }
                State::Headers { length, bad, seen } => {
                    let nl = rest.iter().position(|&b| b == b'\n')?;
                    let mut line = &rest[..nl];
                    if line.last() == Some(&b'\r') {
                        line = &line[..line.len() - 1];
                    }
                    let line = line.to_vec();
                    self.at += nl + 1;
                    if line.is_empty() {
                        if !*seen {
                            // A blank line between messages, or inside garbage.
                            continue;
                        }
                        let (len, why) = (length.take(), bad.take());
                        self.state = State::headers();
                        match (why, len) {
                            (Some((why, skip)), _) => {
                                if skip > 0 {
                                    self.state = State::Skip(skip);
                                } else {
                                    // The body of unknown length follows:
                                    // skipped with the message, unreported.
                                    self.garbage = true;
                                }
                                return Some(Event::Bad(why));
                            }
                            (None, Some(n)) => self.state = State::Body(n),
                            (None, None) => {
                                return Some(Event::Bad(
                                    "a message without a Content-Length header".into(),
                                ));
                            }
                        }
                        continue;
                    }
                    let mut report = None;
                    if let Some(i) = find_ci(&line, CONTENT_LENGTH) {
                        if i > 0 && !self.garbage {
                            report = Some("bytes before a header that are not a message".into());
                        }
                        self.garbage = false;
                        *seen = true;
                        let value = String::from_utf8_lossy(&line[i + CONTENT_LENGTH.len()..]);
                        match value.trim().parse::<u64>() {
                            Ok(n) if n <= self.max as u64 => {
                                *length = Some(n as usize);
                            }
                            Ok(n) => {
                                *bad = Some((
                                    format!(
                                        "a body of {n} bytes, over the {} this server reads",
                                        self.max
                                    ),
                                    usize::try_from(n).unwrap_or(usize::MAX),
                                ));
                            }
                            Err(_) => {
                                *bad = Some((format!("a Content-Length of `{}`", value.trim()), 0));
                            }
                        }
                    } else if is_header(&line) && !self.garbage {
                        // Content-Type or another header: not needed.
                        *seen = true;
                    } else {
                        if !self.garbage {
                            report = Some("bytes that are not a message (no header)".into());
                        }
                        self.garbage = true;
                        *seen = false;
                        *length = None;
                        *bad = None;
                    }
                    if let Some(r) = report {
                        return Some(Event::Bad(r));
                    }
                }
            }
        }
    }
}

/// `Name: value` with a token for a name.
fn is_header(line: &[u8]) -> bool {
    match line.iter().position(|&b| b == b':') {
        Some(i) if i > 0 => line[..i]
            .iter()
            .all(|b| b.is_ascii_alphanumeric() || *b == b'-' || *b == b'_'),
        _ => false,
    }
}

/// A message framed for the wire.
pub fn frame(body: &[u8]) -> Vec<u8> {
    let mut out = format!("Content-Length: {}\r\n\r\n", body.len()).into_bytes();
    out.extend_from_slice(body);
    out
}

/// A JSON-RPC error response body.
fn error_response(code: i64, message: String, id: Value) -> Vec<u8> {
    let v = json!({ "jsonrpc": "2.0", "error": { "code": code, "message": message }, "id": id });
    v.to_string().into_bytes()
}

/// An answer to bytes that were not a message at all.
pub fn parse_error(why: &str) -> Vec<u8> {
    error_response(-32700, format!("Parse error: {why}"), Value::Null)
}

/// Replace each lone UTF-16 surrogate escape (`\uD83C` not followed by a
/// low one, or a low one alone) in JSON text with `\uFFFD`, which has the
/// same length in UTF-16. Escaped backslashes are skipped, so `\\uD83C`
/// (a backslash, then text) is left alone.
pub fn fix_lone_surrogates(body: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    fn hex4(b: &[u8]) -> Option<u16> {
        let s = std::str::from_utf8(b.get(..4)?).ok()?;
        u16::from_str_radix(s, 16).ok()
    }
    // Offsets of escapes to replace.
    let mut lone = Vec::new();
    let mut i = 0;
    let mut in_string = false;
    while i < body.len() {
        let b = body[i];
        if !in_string {
            in_string = b == b'"';
            i += 1;
            continue;
        }
        match b {
            b'"' => {
                in_string = false;
                i += 1;
            }
            b'\\' if body.get(i + 1) == Some(&b'u') => {
                let Some(u) = hex4(&body[i + 2..]) else {
                    i += 2;
                    continue;
                };
                if (0xD800..0xDC00).contains(&u) {
                    let low = (body.get(i + 6) == Some(&b'\\') && body.get(i + 7) == Some(&b'u'))
                        .then(|| hex4(&body[i + 8..]))
                        .flatten()
                        .filter(|l| (0xDC00..0xE000).contains(l));
                    if low.is_some() {
                        i += 12;
                    } else {
                        lone.push(i);
                        i += 6;
                    }
                } else {
                    if (0xDC00..0xE000).contains(&u) {
                        lone.push(i);
                    }
                    i += 6;
                }
            }
            b'\\' => i += 2,
            _ => i += 1,
        }
    }
    if lone.is_empty() {
        return std::borrow::Cow::Borrowed(body);
    }
    let mut out = body.to_vec();
    for at in lone {
        out[at..at + 6].copy_from_slice(b"\\uFFFD");
    }
    std::borrow::Cow::Owned(out)
}

/// Whether a JSON value is a valid JSON-RPC id (a string, an integer, or
/// null).
fn valid_id(v: &Value) -> bool {
    match v {
        Value::String(_) | Value::Null => true,
        Value::Number(n) => n.is_i64() || n.is_u64(),
        _ => false,
    }
}

/// LSP methods that take no parameters.
fn no_params(method: &str) -> bool {
    matches!(method, "shutdown" | "exit")
}

/// A body the server may read (possibly with lone surrogates replaced,
/// or empty `params` removed),
/// or the error response to send instead.
pub fn check(body: &[u8]) -> Result<Vec<u8>, Vec<u8>> {
    let body = fix_lone_surrogates(body);
    let v: Value = match serde_json::from_slice(&body) {
        Ok(v) => v,
        Err(e) => return Err(parse_error(&e.to_string())),
    };
    let invalid = |why: &str, id: Value| {
        Err(error_response(
            -32600,
            format!("Invalid Request: {why}"),
            id,
        ))
    };
    let Value::Object(m) = &v else {
        return invalid(
            "a message must be a JSON object (batches are not used by LSP)",
            Value::Null,
        );
    };
    let id = m.get("id");
    let id_out = id.filter(|i| valid_id(i)).cloned().unwrap_or(Value::Null);
    if m.get("jsonrpc").and_then(Value::as_str) != Some("2.0") {
        return invalid("`jsonrpc` must be \"2.0\"", id_out);
    }
    if let Some(i) = id
        && !valid_id(i)
    {
        return invalid("`id` must be a string or an integer", Value::Null);
    }
    match m.get("method") {
        Some(Value::String(method)) => {
            // `"params": null` is what several clients send for "none"
            // (Eglot, lsp4ij), and `{}` or `[]` for `shutdown` and `exit`,
            // which take none: the server reads them as no params (it
            // refused them, and a refused `exit` left it running).
            let empty = match m.get("params") {
                None => false,
                Some(Value::Null) => true,
                Some(Value::Object(o)) => o.is_empty() && no_params(method),
                Some(Value::Array(a)) => a.is_empty() && no_params(method),
                Some(_) => {
                    return invalid("`params` must be an object or an array", id_out);
                }
            };
            if empty {
                let mut m = m.clone();
                m.remove("params");
                return Ok(Value::Object(m).to_string().into_bytes());
            }
        }
        Some(_) => return invalid("`method` must be a string", id_out),
        None => {
            // A response to one of the server's requests.
            let one = m.contains_key("result") != m.contains_key("error");
            if id.is_none() || !one {
                return invalid(
                    "neither a request (no `method`) nor a response (an `id` and one of `result`, `error`)",
                    id_out,
                );
            }
        }
    }
    Ok(body.into_owned())
}

/// Copy framed messages from `input` to the server's input, checked;
/// answers for what is dropped go to `answers`.
pub async fn guard_input(
    mut input: impl AsyncRead + Unpin,
    mut server: impl AsyncWrite + Unpin,
    answers: tokio::sync::mpsc::UnboundedSender<Vec<u8>>,
) {
    let mut d = Deframer::default();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = match input.read(&mut buf).await {
            Ok(0) | Err(_) => break,
            Ok(n) => n,
        };
        d.push(&buf[..n]);
        while let Some(ev) = d.next_event() {
            let answer = match ev {
                Event::Body(b) => match check(&b) {
                    Ok(body) => {
                        if server.write_all(&frame(&body)).await.is_err() {
                            return;
                        }
                        continue;
                    }
                    Err(a) => a,
                },
                Event::Bad(why) => parse_error(&why),
            };
            let _ = answers.send(answer);
        }
        if server.flush().await.is_err() {
            return;
        }
    }
    // End of input: the server sees it too.
    let _ = server.shutdown().await;
}

/// The id of a response the server wrote (tower-lsp-server writes a
/// response's `id` last: `..., "id": 7}`), read from its end alone.
fn response_id(body: &[u8]) -> Option<Value> {
    let tail = &body[body.len().saturating_sub(512)..];
    let at = tail.windows(5).rposition(|w| w == b"\"id\":")?;
    let rest = tail[at + 5..].strip_suffix(b"}")?;
    let id: Value = serde_json::from_slice(rest).ok()?;
    valid_id(&id).then_some(id)
}

/// What goes to the client for one of the server's messages: the message,
/// or, for a response longer than [`MAX_BODY`] (which a client reading
/// with the same limit would drop, and then wait for forever), an error
/// answering its request (RequestFailed, -32803); a notification that long
/// is dropped.
pub fn outgoing(body: Vec<u8>) -> Option<Vec<u8>> {
    outgoing_within(body, MAX_BODY)
}

/// [`outgoing`] with a limit of `max` bytes.
fn outgoing_within(body: Vec<u8>, max: usize) -> Option<Vec<u8>> {
    if body.len() <= max {
        return Some(body);
    }
    let id = response_id(&body)?;
    Some(error_response(
        -32803,
        format!(
            "the answer would be {:.1} MiB, over the limit of {:.1} MiB on a message",
            body.len() as f64 / f64::from(1 << 20),
            max as f64 / f64::from(1 << 20)
        ),
        id,
    ))
}

/// Writes a blob's frame (protocol 3, [`crate::blob`]).
async fn write_blob(
    output: &mut (impl AsyncWrite + Unpin),
    blob: &crate::blob::Blob,
) -> std::io::Result<()> {
    output.write_all(&crate::blob::frame_header(blob)).await?;
    for c in &blob.chunks {
        output.write_all(c).await?;
    }
    Ok(())
}

/// Copy the server's messages to `output`, with the guard's answers
/// between them; ends when the server's output ends. A message of the
/// server's is never dropped unanswered ([`outgoing`]). The server's blobs
/// (protocol 3) are written as frames of their own, each before any
/// message of the server's read after it was sent: before the answer or
/// notification that names it.
pub async fn merge_output(
    mut server: impl AsyncRead + Unpin,
    mut output: impl AsyncWrite + Unpin,
    mut answers: tokio::sync::mpsc::UnboundedReceiver<Vec<u8>>,
    mut blobs: tokio::sync::mpsc::UnboundedReceiver<crate::blob::Blob>,
) {
    let mut d = Deframer::with_max(usize::MAX);
    let mut buf = vec![0u8; 1 << 16];
    loop {
        tokio::select! {
            r = server.read(&mut buf) => {
                let n = match r {
                    Ok(0) | Err(_) => break,
                    Ok(n) => n,
                };
                d.push(&buf[..n]);
                // Sent before these messages were written: before the one
                // that names it.
                while let Ok(blob) = blobs.try_recv() {
                    if write_blob(&mut output, &blob).await.is_err() {
                        return;
                    }
                }
                while let Some(ev) = d.next_event() {
                    if let Event::Body(b) = ev
                        && let Some(b) = outgoing(b)
                        && output.write_all(&frame(&b)).await.is_err()
                    {
                        return;
                    }
                }
            }
            Some(a) = answers.recv() => {
                if output.write_all(&frame(&a)).await.is_err() {
                    return;
                }
            }
        }
        if output.flush().await.is_err() {
            return;
        }
    }
    while let Ok(a) = answers.try_recv() {
        let _ = output.write_all(&frame(&a)).await;
    }
    let _ = output.flush().await;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn events(chunks: &[&[u8]]) -> Vec<Event> {
        let mut d = Deframer::with_max(1000);
        let mut out = Vec::new();
        for c in chunks {
            d.push(c);
            while let Some(e) = d.next_event() {
                out.push(e);
            }
        }
        out
    }

    fn body(s: &str) -> Event {
        Event::Body(s.as_bytes().to_vec())
    }

    #[test]
    fn frames_split_anywhere_and_tolerant_headers() {
        let wire = b"Content-Length: 2\r\n\r\n{}content-length:3\nContent-Type: application/vscode-jsonrpc; charset=utf-8\n\n[1]";
        // Every split point gives the same messages.
        for cut in 0..wire.len() {
            let got = events(&[&wire[..cut], &wire[cut..]]);
            assert_eq!(got, [body("{}"), body("[1]")], "cut at {cut}");
        }
    }

    #[test]
    fn garbage_is_reported_once_and_the_next_message_read() {
        let got = events(&[b"{{{{{\nmore junk\r\n\r\nContent-Length: 2\r\n\r\n{}"]);
        assert!(matches!(&got[0], Event::Bad(_)), "{got:?}");
        assert_eq!(got[1..], [body("{}")]);
        // A body sent without headers, then a message on the same line.
        let got = events(&[b"{\"a\":1}Content-Length: 2\r\n\r\n{}"]);
        assert_eq!(got.len(), 2, "{got:?}");
        assert!(matches!(&got[0], Event::Bad(_)));
        assert_eq!(got[1], body("{}"));
        // Bad lengths: unparsable (the body then reads as garbage), too
        // large (skipped), missing.
        // (one answer for the message: its body is skipped unreported).
        let got = events(&[b"Content-Length: abc\r\n\r\n{}\r\nContent-Length: 1\r\n\r\n1"]);
        assert_eq!(got.len(), 2, "{got:?}");
        assert!(matches!(&got[0], Event::Bad(m) if m.contains("abc")));
        assert_eq!(got[1], body("1"));
        let huge = "Content-Length: 1001\r\n\r\n";
        let got = events(&[
            huge.as_bytes(),
            &[b'x'; 1001],
            b"Content-Length: 1\r\n\r\n2",
        ]);
        assert_eq!(got.len(), 2);
        assert!(matches!(&got[0], Event::Bad(m) if m.contains("over")));
        assert_eq!(got[1], body("2"));
        let got = events(&[b"Content-Length: 99999999999999999999999\r\n\r\n"]);
        assert!(matches!(&got[..], [Event::Bad(_)]), "{got:?}");
        let got = events(&[b"Content-Type: x\r\n\r\nContent-Length: 1\r\n\r\n3"]);
        assert!(matches!(&got[0], Event::Bad(m) if m.contains("without a Content-Length")));
        assert_eq!(got[1], body("3"));
    }

    #[test]
    fn messages_are_checked() {
        let ok = |s: &str| check(s.as_bytes()).map(|b| String::from_utf8(b).unwrap());
        let err = |s: &str| -> Value {
            serde_json::from_slice(&check(s.as_bytes()).expect_err(s)).unwrap()
        };
        assert!(ok(r#"{"jsonrpc":"2.0","id":1,"method":"initialize","params":{}}"#).is_ok());
        assert!(ok(r#"{"jsonrpc":"2.0","method":"initialized"}"#).is_ok());
        assert!(ok(r#"{"jsonrpc":"2.0","id":"a","result":null}"#).is_ok());
        assert_eq!(err("{{{{{")["error"]["code"], -32700);
        assert_eq!(err("[]")["error"]["code"], -32600);
        assert_eq!(err("5")["error"]["code"], -32600);
        assert_eq!(err("null")["error"]["code"], -32600);
        let e = err(r#"{"jsonrpc":"1.0","id":7,"method":"x"}"#);
        assert_eq!(
            (e["error"]["code"].clone(), e["id"].clone()),
            (json!(-32600), json!(7))
        );
        assert_eq!(err(r#"{"id":7,"method":"x"}"#)["id"], 7);
        assert_eq!(
            err(r#"{"jsonrpc":"2.0","id":1.5,"method":"x"}"#)["id"],
            Value::Null
        );
        assert_eq!(
            err(r#"{"jsonrpc":"2.0","id":{"a":1},"method":"x"}"#)["error"]["code"],
            -32600
        );
        assert_eq!(
            err(r#"{"jsonrpc":"2.0","id":1,"method":3}"#)["error"]["code"],
            -32600
        );
        assert_eq!(
            err(r#"{"jsonrpc":"2.0","id":1,"method":"x","params":3}"#)["error"]["code"],
            -32600
        );
        assert_eq!(err(r#"{"jsonrpc":"2.0","id":1}"#)["error"]["code"], -32600);
        // Empty params where there are none to give: read as none.
        for m in [
            r#"{"jsonrpc":"2.0","id":2,"method":"shutdown","params":null}"#,
            r#"{"jsonrpc":"2.0","id":2,"method":"shutdown","params":{}}"#,
            r#"{"jsonrpc":"2.0","method":"exit","params":[]}"#,
            r#"{"jsonrpc":"2.0","method":"initialized","params":null}"#,
        ] {
            let v: Value = serde_json::from_str(&ok(m).expect(m)).unwrap();
            assert!(v.get("params").is_none(), "{m}: {v}");
        }
        let kept: Value = serde_json::from_str(
            &ok(r#"{"jsonrpc":"2.0","method":"initialized","params":{}}"#).unwrap(),
        )
        .unwrap();
        assert_eq!(kept["params"], json!({}));
        assert_eq!(err("\u{1}")["error"]["code"], -32700);
        let bad_utf8 = check(b"{\"jsonrpc\":\"2.0\",\"method\":\"\xff\"}").expect_err("utf-8");
        assert!(String::from_utf8_lossy(&bad_utf8).contains("-32700"));
        let deep = "[".repeat(100_000);
        assert_eq!(err(&deep)["error"]["code"], -32700);
    }

    #[test]
    fn an_answer_over_the_limit_becomes_an_error_for_its_request() {
        let small = br#"{"jsonrpc":"2.0","result":{"a":1},"id":3}"#.to_vec();
        assert_eq!(outgoing_within(small.clone(), 1000), Some(small));
        let big = format!(
            r#"{{"jsonrpc":"2.0","result":"{}","id":7}}"#,
            "x".repeat(2000)
        );
        let answer = outgoing_within(big.into_bytes(), 1000).expect("answered");
        let v: Value = serde_json::from_slice(&answer).expect("json");
        assert_eq!(v["id"], 7);
        assert_eq!(v["error"]["code"], -32803);
        assert!(
            v["error"]["message"]
                .as_str()
                .unwrap()
                .contains("over the limit")
        );
        let named = format!(
            r#"{{"jsonrpc":"2.0","result":"{}","id":"a"}}"#,
            "x".repeat(2000)
        );
        let v: Value =
            serde_json::from_slice(&outgoing_within(named.into_bytes(), 1000).unwrap()).unwrap();
        assert_eq!(v["id"], "a");
        // A notification has no request waiting for it.
        let note = format!(
            r#"{{"jsonrpc":"2.0","method":"m","params":["{}"]}}"#,
            "x".repeat(2000)
        );
        assert_eq!(outgoing_within(note.into_bytes(), 1000), None);
    }

    #[test]
    fn lone_surrogates_become_replacement_characters() {
        let m = r#"{"jsonrpc":"2.0","method":"x","params":{"text":"a\ud83cb\udf33c\ud83c\udf33\\ud83c"}}"#;
        let fixed = check(m.as_bytes()).expect("accepted");
        let v: Value = serde_json::from_slice(&fixed).unwrap();
        // Lone high and low: one U+FFFD each (one UTF-16 unit for one); a
        // pair stays; an escaped backslash is text.
        assert_eq!(v["params"]["text"], "a\u{FFFD}b\u{FFFD}c\u{1F333}\\ud83c");
        let plain = br#"{"a":"\u00e9"}"#;
        assert!(matches!(
            fix_lone_surrogates(plain),
            std::borrow::Cow::Borrowed(_)
        ));
    }

    /// The two pumps together: a bad message between good ones is answered
    /// between the server's answers, and input that ends ends the output.
    #[tokio::test]
    async fn pumps_answer_bad_messages_in_between() {
        let (mut client_w, stdin) = tokio::io::duplex(4096);
        let (server_in_w, mut server_in_r) = tokio::io::duplex(4096);
        let (mut server_out_w, server_out_r) = tokio::io::duplex(4096);
        let (stdout_w, mut stdout_r) = tokio::io::duplex(1 << 16);
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        let guard = tokio::spawn(guard_input(stdin, server_in_w, tx));
        let (_blobs, blobs_rx) = tokio::sync::mpsc::unbounded_channel();
        let merge = tokio::spawn(merge_output(server_out_r, stdout_w, rx, blobs_rx));
        let good = br#"{"jsonrpc":"2.0","id":1,"method":"a"}"#;
        client_w.write_all(&frame(good)).await.unwrap();
        client_w.write_all(&frame(b"{oops")).await.unwrap();
        client_w.write_all(&frame(good)).await.unwrap();
        drop(client_w);
        let mut got = Vec::new();
        server_in_r.read_to_end(&mut got).await.unwrap();
        let mut want = frame(good);
        want.extend(frame(good));
        assert_eq!(got, want, "the server reads the good messages only");
        guard.await.unwrap();
        server_out_w.write_all(&frame(b"{\"x\":1}")).await.unwrap();
        drop(server_out_w);
        merge.await.unwrap();
        let mut out = Vec::new();
        stdout_r.read_to_end(&mut out).await.unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("-32700"), "{text}");
        assert!(text.contains("{\"x\":1}"), "{text}");
    }

    /// A blob sent before a message of the server's is written, as a frame
    /// of its own, before it.
    #[tokio::test]
    async fn blobs_go_before_the_message_that_names_them() {
        let (mut server_out_w, server_out_r) = tokio::io::duplex(4096);
        let (stdout_w, mut stdout_r) = tokio::io::duplex(1 << 16);
        let (_tx, rx) = tokio::sync::mpsc::unbounded_channel();
        let (blobs, blobs_rx) = tokio::sync::mpsc::unbounded_channel();
        let merge = tokio::spawn(merge_output(server_out_r, stdout_w, rx, blobs_rx));
        blobs
            .send(crate::blob::Blob {
                id: 7,
                chunks: vec![vec![0, 1, 2, 3], vec![255; 4]],
            })
            .unwrap();
        server_out_w
            .write_all(&frame(br#"{"blob":{"id":7}}"#))
            .await
            .unwrap();
        drop(server_out_w);
        merge.await.unwrap();
        let mut out = Vec::new();
        stdout_r.read_to_end(&mut out).await.unwrap();
        let mut want =
            b"Content-Length: 8\r\nContent-Type: application/vnd.grm.blob\r\nGrm-Blob: 7\r\n\r\n"
                .to_vec();
        want.extend([0, 1, 2, 3, 255, 255, 255, 255]);
        want.extend(frame(br#"{"blob":{"id":7}}"#));
        assert_eq!(out, want);
    }
}

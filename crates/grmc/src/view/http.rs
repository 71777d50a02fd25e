//! HTTP by hand on `std::net` for `grmc view` (see the parent module):
//! reading a request within the size limits, the answers (the page,
//! JSON, blobs, `Server-Timing`), the `Host` and `Origin` checks, and one
//! connection's dispatch to the in-process language server.

use super::*;

/// A parsed request.
#[derive(Debug, PartialEq, Eq)]
pub(super) struct HttpRequest {
    pub(super) method: String,
    pub(super) target: String,
    pub(super) headers: Vec<(String, String)>,
    pub(super) body: Vec<u8>,
}

impl HttpRequest {
    pub(super) fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    /// How many times the header `name` comes.
    pub(super) fn count(&self, name: &str) -> usize {
        self.headers
            .iter()
            .filter(|(k, _)| k.eq_ignore_ascii_case(name))
            .count()
    }
}

/// An HTTP token (a header field name): visible characters but delimiters.
pub(super) fn is_token(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"!#$%&'*+-.^_`|~".contains(&b))
}

/// Read one request: request line, headers, a `Content-Length` body.
pub(super) fn read_request(r: &mut impl BufRead) -> Result<HttpRequest, (u16, String)> {
    let bad = |m: &str| (400, m.to_string());
    let mut head = 0usize;
    let mut line = String::new();
    let mut read_line = |line: &mut String| -> Result<(), (u16, String)> {
        line.clear();
        let n = r
            .by_ref()
            .take((MAX_HEAD - head.min(MAX_HEAD)) as u64 + 1)
            .read_line(line)
            .map_err(|e| (400, e.to_string()))?;
        head += n;
        if head > MAX_HEAD {
            return Err((431, "request head too large".into()));
        }
        if n == 0 {
            return Err(bad("connection closed"));
        }
        Ok(())
    };
    read_line(&mut line)?;
    let mut parts = line.split_whitespace();
    let (Some(method), Some(target), Some(version)) = (parts.next(), parts.next(), parts.next())
    else {
        return Err(bad("malformed request line"));
    };
    if !version.starts_with("HTTP/1.") {
        return Err((505, "HTTP/1.x only".into()));
    }
    let (method, target) = (method.to_string(), target.to_string());
    let mut headers = Vec::new();
    loop {
        read_line(&mut line)?;
        let l = line.trim_end_matches(['\r', '\n']);
        if l.is_empty() {
            break;
        }
        let (k, v) = l.split_once(':').ok_or_else(|| bad("malformed header"))?;
        // A field name is a token: no space before the colon, no folded
        // continuation line (RFC 9112 5.1, 5.2: a server must refuse them;
        // a proxy in front could read them otherwise).
        if !is_token(k) {
            return Err(bad("malformed header name"));
        }
        headers.push((k.to_string(), v.trim().to_string()));
    }
    let mut req = HttpRequest {
        method,
        target,
        headers,
        body: Vec::new(),
    };
    // One Host, one Content-Length, at most one Transfer-Encoding: two (the
    // same or not) are how requests are smuggled past a proxy, and which
    // one counts is ambiguous (RFC 9112 3.2, 6.3).
    for name in ["host", "content-length", "transfer-encoding"] {
        if req.count(name) > 1 {
            return Err(bad(&format!("more than one {name} header")));
        }
    }
    if req
        .header("transfer-encoding")
        .is_some_and(|t| !t.eq_ignore_ascii_case("identity"))
    {
        return Err((411, "send a Content-Length".into()));
    }
    if let Some(len) = req.header("content-length") {
        // Digits only (`+5`, `5, 5` and ` ` are not lengths).
        if len.is_empty() || !len.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad("bad Content-Length"));
        }
        let len: usize = len.parse().map_err(|_| bad("bad Content-Length"))?;
        if len > MAX_BODY {
            return Err((413, "request body too large".into()));
        }
        req.body = vec![0; len];
        r.read_exact(&mut req.body)
            .map_err(|e| (400, e.to_string()))?;
    }
    Ok(req)
}

pub(super) fn respond(
    w: &mut impl Write,
    status: u16,
    content_type: &str,
    body: &[u8],
) -> std::io::Result<()> {
    respond_with(w, status, content_type, body, "")
}

/// An answer with `extra` headers (each line ending in CRLF).
pub(super) fn respond_with(
    w: &mut impl Write,
    status: u16,
    content_type: &str,
    body: &[u8],
    extra: &str,
) -> std::io::Result<()> {
    let reason = match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        411 => "Length Required",
        413 => "Payload Too Large",
        431 => "Request Header Fields Too Large",
        _ => "Error",
    };
    // One write for head and body: small writes on a socket would wait for
    // the client's delayed ACK (Nagle), about 40 ms each.
    let mut out = format!(
        "HTTP/1.1 {status} {reason}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nContent-Security-Policy: {CSP}; {CSP_FRAMES}\r\n{extra}Connection: close\r\n\r\n",
        body.len()
    )
    .into_bytes();
    out.extend_from_slice(body);
    w.write_all(&out)?;
    w.flush()
}

/// A preview's blob (protocol 3) as `application/octet-stream`.
pub(super) fn respond_blob(w: &mut impl Write, blob: &grm_lsp::blob::Blob) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 200 OK\r\nContent-Type: application/octet-stream\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nContent-Security-Policy: {CSP}; {CSP_FRAMES}\r\nConnection: close\r\n\r\n",
        blob.len()
    );
    // One buffer: small writes would wait for the client's delayed ACK.
    let mut out = Vec::with_capacity(head.len() + blob.len());
    out.extend_from_slice(head.as_bytes());
    for c in &blob.chunks {
        out.extend_from_slice(c);
    }
    w.write_all(&out)?;
    w.flush()
}

pub(super) fn respond_json(w: &mut impl Write, status: u16, v: &Value) -> std::io::Result<()> {
    respond(w, status, "application/json", v.to_string().as_bytes())
}

/// `Host` must name this server: a page from elsewhere that resolves its
/// own name to 127.0.0.1 (DNS rebinding) is refused.
pub(super) fn host_ok(req: &HttpRequest, addr: SocketAddr) -> bool {
    let port = addr.port();
    req.header("host")
        .is_some_and(|h| h == format!("127.0.0.1:{port}") || h == format!("localhost:{port}"))
}

/// A POST from a page of another origin is refused (no CORS).
pub(super) fn origin_ok(req: &HttpRequest, addr: SocketAddr) -> bool {
    let port = addr.port();
    req.header("origin").is_none_or(|o| {
        o == format!("http://127.0.0.1:{port}") || o == format!("http://localhost:{port}")
    })
}

pub(super) fn handle(st: &State, stream: TcpStream) -> std::io::Result<()> {
    // A client that connects and says nothing does not hold a thread forever.
    stream.set_read_timeout(Some(Duration::from_secs(30)))?;
    stream.set_nodelay(true)?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut w = stream;
    let req = match read_request(&mut reader) {
        Ok(r) => r,
        Err((status, msg)) => return respond_json(&mut w, status, &json!({ "error": msg })),
    };
    if !host_ok(&req, st.addr) {
        return respond_json(&mut w, 403, &json!({ "error": "wrong Host" }));
    }
    let (path, query) = req
        .target
        .split_once('?')
        .unwrap_or((req.target.as_str(), ""));
    match (req.method.as_str(), path) {
        ("GET", "/" | "/index.html") => respond(
            &mut w,
            200,
            "text/html; charset=utf-8",
            index_html().as_bytes(),
        ),
        ("GET", "/preview.js") => respond(
            &mut w,
            200,
            "text/javascript; charset=utf-8",
            PREVIEW_JS.as_bytes(),
        ),
        ("GET", "/preview.css") => respond(
            &mut w,
            200,
            "text/css; charset=utf-8",
            PREVIEW_CSS.as_bytes(),
        ),
        ("GET", "/api/events") => {
            let arg = |name: &str| -> Option<u64> {
                query
                    .split('&')
                    .find_map(|kv| kv.strip_prefix(name)?.strip_prefix('='))
                    .and_then(|v| v.parse().ok())
            };
            let wait = arg("wait").map_or(POLL_WAIT, |ms| Duration::from_millis(ms).min(POLL_WAIT));
            respond_json(
                &mut w,
                200,
                &st.events.after(arg("after").unwrap_or(0), wait),
            )
        }
        ("GET", p) if p.starts_with("/api/blob/") => {
            match p["/api/blob/".len()..]
                .parse()
                .ok()
                .and_then(|id| st.blobs.get(id))
            {
                Some(blob) => respond_blob(&mut w, &blob),
                None => respond_json(
                    &mut w,
                    404,
                    &json!({ "error": "no such blob (kept: the newest previews')" }),
                ),
            }
        }
        ("POST", p) if p.starts_with("/api/") => {
            if !origin_ok(&req, st.addr) {
                return respond_json(&mut w, 403, &json!({ "error": "cross-origin request" }));
            }
            let params: Value = match serde_json::from_slice(&req.body) {
                Ok(v) => v,
                Err(e) => {
                    return respond_json(
                        &mut w,
                        400,
                        &json!({ "error": format!("invalid JSON: {e}") }),
                    );
                }
            };
            let started = Instant::now();
            // A call the request reached is answered 200 whatever its
            // outcome, like a JSON-RPC reply: a grammar that cannot be
            // previewed is the page's everyday state, not an HTTP failure
            // (browsers log every 4xx answer in the console).
            let answer = match st.api(&p["/api/".len()..], params) {
                Ok(result) => json!({ "result": result }),
                Err(e) => {
                    let mut a = json!({ "error": e.message });
                    if let Some(code) = e.code {
                        a["code"] = json!(code);
                    }
                    if let Some(version) = e.version {
                        a["version"] = json!(version);
                    }
                    a
                }
            };
            let status = 200;
            let body = answer.to_string();
            let timing = format!(
                "Server-Timing: app;dur={:.2}\r\n",
                started.elapsed().as_secs_f64() * 1e3
            );
            respond_with(&mut w, status, "application/json", body.as_bytes(), &timing)
        }
        ("GET" | "POST", _) => respond_json(&mut w, 404, &json!({ "error": "not found" })),
        _ => respond_json(&mut w, 405, &json!({ "error": "GET or POST" })),
    }
}

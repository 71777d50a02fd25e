use super::*;

/// A classic grammar small enough for every request.
const KOCH: &str = "system Koch {\n    iterations = 2;\n    angle = 90;\n    width = 0.1;\n    axiom F - F - F - F;\n    F -> F - F + F + F F - F - F + F;\n}\n";

/// `text` written to `name` in a fresh folder (which lives as long as
/// the first value) and a server started on it; the grammar's path as
/// the server names it.
fn serve(name: &str, text: &str) -> (tempfile::TempDir, PathBuf, Server) {
    let dir = tempfile::tempdir().expect("tempdir");
    let grammar = dir.path().join(name);
    std::fs::write(&grammar, text).expect("write");
    let grammar = grm_sema::normalize(&std::fs::canonicalize(&grammar).expect("canonical"));
    let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
    let server = Server::start(&grammar, listener, None).expect("start");
    (dir, grammar, server)
}

fn parse(raw: &str) -> Result<HttpRequest, (u16, String)> {
    read_request(&mut BufReader::new(raw.as_bytes()))
}

#[test]
fn requests_are_parsed_with_their_body() {
    let r = parse(
        "POST /api/pick HTTP/1.1\r\nHost: 127.0.0.1:9\r\nContent-Length: 4\r\n\r\n{}\r\nextra",
    )
    .expect("parses");
    assert_eq!(r.method, "POST");
    assert_eq!(r.target, "/api/pick");
    assert_eq!(r.header("HOST"), Some("127.0.0.1:9"));
    assert_eq!(r.body, b"{}\r\n");
}

#[test]
fn malformed_and_oversized_requests_are_refused() {
    assert_eq!(parse("GARBAGE\r\n\r\n").unwrap_err().0, 400);
    assert_eq!(parse("GET / HTTP/2\r\n\r\n").unwrap_err().0, 505);
    assert_eq!(
        parse("GET / HTTP/1.1\r\nNoColon\r\n\r\n").unwrap_err().0,
        400
    );
    let big = format!(
        "POST / HTTP/1.1\r\nContent-Length: {}\r\n\r\n",
        MAX_BODY + 1
    );
    assert_eq!(parse(&big).unwrap_err().0, 413);
    let long = format!("GET / HTTP/1.1\r\nX: {}\r\n\r\n", "a".repeat(MAX_HEAD));
    assert_eq!(parse(&long).unwrap_err().0, 431);
    assert_eq!(
        parse("POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n")
            .unwrap_err()
            .0,
        411
    );
    assert_eq!(
        parse("POST / HTTP/1.1\r\nContent-Length: 10\r\n\r\nshort")
            .unwrap_err()
            .0,
        400
    );
}

#[test]
fn duplicate_conflicting_and_malformed_framing_headers_are_refused() {
    let req = |headers: &str| format!("POST /api/pick HTTP/1.1\r\n{headers}\r\n{{}}\r\n");
    let ok = "Host: 127.0.0.1:9\r\nContent-Length: 2\r\n";
    assert_eq!(parse(&req(ok)).expect("one of each").body, b"{}");
    for bad in [
        // Two Hosts: which one was checked against DNS rebinding?
        "Host: 127.0.0.1:9\r\nHost: evil.example\r\nContent-Length: 2\r\n",
        "Host: 127.0.0.1:9\r\nhost: 127.0.0.1:9\r\nContent-Length: 2\r\n",
        // Two lengths, conflicting or not: where does the next request begin?
        "Host: 127.0.0.1:9\r\nContent-Length: 2\r\nContent-Length: 4\r\n",
        "Host: 127.0.0.1:9\r\nContent-Length: 2\r\nContent-Length: 2\r\n",
        "Host: 127.0.0.1:9\r\nContent-Length: 2, 2\r\n",
        "Host: 127.0.0.1:9\r\nContent-Length: +2\r\n",
        "Host: 127.0.0.1:9\r\nContent-Length: \r\n",
        "Host: 127.0.0.1:9\r\nTransfer-Encoding: identity\r\nTransfer-Encoding: identity\r\nContent-Length: 2\r\n",
        // A space before the colon, a folded line.
        "Host : 127.0.0.1:9\r\nContent-Length: 2\r\n",
        "Host: 127.0.0.1:9\r\nContent-Length: 2\r\nX-A: 1\r\n  folded\r\n",
    ] {
        assert_eq!(
            parse(&req(bad)).map(|r| r.headers).unwrap_err().0,
            400,
            "{bad:?}"
        );
    }
}

#[test]
fn host_and_origin_must_be_this_server() {
    let addr: SocketAddr = "127.0.0.1:4321".parse().expect("addr");
    let req = |h: &[(&str, &str)]| HttpRequest {
        method: "POST".into(),
        target: "/".into(),
        headers: h
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        body: vec![],
    };
    assert!(host_ok(&req(&[("Host", "127.0.0.1:4321")]), addr));
    assert!(host_ok(&req(&[("host", "localhost:4321")]), addr));
    assert!(!host_ok(&req(&[("Host", "evil.example:4321")]), addr));
    assert!(!host_ok(&req(&[]), addr));
    assert!(origin_ok(&req(&[]), addr));
    assert!(origin_ok(
        &req(&[("Origin", "http://127.0.0.1:4321")]),
        addr
    ));
    assert!(!origin_ok(&req(&[("Origin", "http://evil.example")]), addr));
}

#[test]
fn events_wait_and_report_what_came_after() {
    let q = EventQueue {
        events: Mutex::new(Events::default()),
        changed: Condvar::new(),
    };
    q.push("document", json!({ "uri": "u" }));
    let first = q.after(0, Duration::ZERO);
    assert_eq!(first["seq"], 1);
    assert_eq!(first["events"][0]["method"], "document");
    // Nothing new: an empty answer after the wait.
    let t = Instant::now();
    let none = q.after(1, Duration::from_millis(50));
    assert!(t.elapsed() >= Duration::from_millis(50));
    assert_eq!(none["events"].as_array().map(Vec::len), Some(0));
    for i in 0..(EVENT_LOG + 10) {
        q.push("previewUpdated", json!({ "n": i }));
    }
    let behind = q.after(1, Duration::ZERO);
    assert_eq!(behind["events"].as_array().map(Vec::len), Some(EVENT_LOG));
    assert_eq!(behind["seq"], (EVENT_LOG + 11) as u64);
    assert_eq!(behind["events"][0]["params"]["n"], 10);
    // A page opened late still learns its document first.
    let late = q.after(0, Duration::ZERO);
    assert_eq!(late["events"][0]["method"], "document");
    assert_eq!(late["events"].as_array().map(Vec::len), Some(EVENT_LOG + 1));
}

#[test]
fn an_empty_grammar_is_taken_only_once_it_stays_empty() {
    let looks = std::sync::atomic::AtomicU32::new(0);
    // Saved in place: truncated (one look finds it empty), then written.
    assert!(!settled("", &looks));
    assert!(settled("system A { axiom F; }", &looks));
    // Emptied for good: taken at the fourth look in a row, once.
    assert_eq!(
        (0..EMPTY_LOOKS)
            .map(|_| settled("", &looks))
            .collect::<Vec<_>>(),
        [false, false, false, true]
    );
    assert!(settled("x", &looks));
    assert!(!settled("", &looks), "counted afresh");
}

#[test]
fn the_curves_file_is_named_after_the_grammar() {
    assert_eq!(
        curves_path_for(Path::new("/a/calder_tree.grm")),
        PathBuf::from("/a/calder_tree.curves.json")
    );
}

/// One HTTP exchange with a running server: the answer's head and body.
fn exchange_raw(addr: SocketAddr, raw: &str) -> (String, String) {
    let mut s = TcpStream::connect(addr).expect("connect");
    s.write_all(raw.as_bytes()).expect("send");
    let mut out = String::new();
    s.read_to_string(&mut out).expect("read");
    let (head, body) = out.split_once("\r\n\r\n").unwrap_or((out.as_str(), ""));
    (head.to_string(), body.to_string())
}

/// One HTTP exchange with a running server.
fn exchange(addr: SocketAddr, raw: &str) -> (u16, Value) {
    let (head, body) = exchange_raw(addr, raw);
    let status = head[9..12].parse().expect("status");
    (
        status,
        serde_json::from_str(&body).unwrap_or(Value::String(body)),
    )
}

fn post(addr: SocketAddr, path: &str, body: &Value) -> (u16, Value) {
    let b = body.to_string();
    exchange(
        addr,
        &format!(
            "POST {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{b}",
            b.len()
        ),
    )
}

/// A server for a sample grammar of a hundred thousand generations
/// (minutes, unless a budget or a newer request stops it), its
/// document's URI and one guiding curve; the folder lives as long as
/// the first value.
/// The server's first events (the `document` event first) and the URI
/// that event names, which the page uses in its requests.
fn first_events(addr: SocketAddr) -> (Value, Value) {
    let (_, ev) = exchange(
        addr,
        &format!("GET /api/events?after=0 HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
    );
    let uri = ev["events"][0]["params"]["uri"].clone();
    (ev, uri)
}

fn endless_server() -> (tempfile::TempDir, Server, Value, Value) {
    let (dir, _, server) = serve(
        "endless.grm",
        "system Endless {\n    mode = sample;\n    generations = 100000;\n    particles_start = 8;\n    particles_end = 4;\n    axiom branch;\n    skeleton branch, maybe;\n    geometry tip;\n    branch -> roty(uniform(0, 360)) rotz(uniform(0, 40)) F(1) maybe;\n    maybe -> (3) branch;\n    maybe -> (1) tip;\n    wrapup branch -> tip;\n    wrapup maybe -> tip;\n    tip -> sphere(0.1);\n}\n",
    );
    let addr = server.addr;
    let (_, uri) = first_events(addr);
    let curves =
        json!({ "version": 1, "curves": [{ "points": [[0,0,0],[0,1.3,0],[0,2.7,0],[0,4,0]] }] });
    (dir, server, uri, curves)
}

/// Two overlapping previews of one document: the second is not queued
/// behind the first, supersedes it, and the first is answered at once
/// with the server's ServerCancelled code.
#[test]
fn a_newer_preview_supersedes_the_one_in_flight() {
    let (_dir, server, uri, curves) = endless_server();
    let addr = server.addr;
    let req = |budget: u64| json!({ "textDocument": { "uri": uri }, "curves": curves, "live": true, "budgetMs": budget });
    let first_req = req(60_000);
    let first = std::thread::spawn(move || {
        let r = post(addr, "/api/preview", &first_req);
        (r, Instant::now())
    });
    std::thread::sleep(Duration::from_millis(300));
    assert!(!first.is_finished(), "the first preview is being built");
    let t = Instant::now();
    let (status, second) = post(addr, "/api/preview", &req(20));
    assert_eq!(status, 200, "{second}");
    assert_eq!(second["result"]["sample"]["stoppedEarly"], true);
    let ((status, e), answered) = first.join().expect("first");
    // Not a failure (no 4xx for the browser to log), but no model.
    assert_eq!(status, 200, "{e}");
    assert_eq!(e.get("result"), None, "{e}");
    assert_eq!(e["code"], -32802, "{e}");
    assert!(
        e["error"]
            .as_str()
            .is_some_and(|m| m.contains("superseded")),
        "{e}"
    );
    assert!(
        answered.duration_since(t) < Duration::from_secs(5),
        "the superseded preview was answered {:?} after the newer one was sent",
        answered.duration_since(t)
    );
}

/// The page's older request reaching the server after its newer one
/// (two connections, two threads): answered superseded at once, and
/// the newer one is not stopped.
#[test]
fn a_pages_older_preview_arriving_late_supersedes_nothing() {
    let (_dir, server, uri, curves) = endless_server();
    let addr = server.addr;
    let req = |order: u64, budget: u64| json!({ "textDocument": { "uri": uri }, "curves": curves, "live": true, "client": "page", "order": order, "budgetMs": budget });
    let newer_req = req(2, 1500);
    let newer = std::thread::spawn(move || post(addr, "/api/preview", &newer_req));
    std::thread::sleep(Duration::from_millis(300));
    assert!(!newer.is_finished(), "the newer preview is being built");
    let t = Instant::now();
    let (status, older) = post(addr, "/api/preview", &req(1, 60_000));
    assert_eq!(status, 200, "{older}");
    assert_eq!(older["code"], -32802, "{older}");
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
    let (status, newer) = newer.join().expect("newer");
    assert_eq!(status, 200, "{newer}");
    // Not stopped by the older request: a model, built until its
    // search ended or its own budget stopped it (which of the two
    // depends on the machine's speed, not on the older request).
    assert!(newer.get("code").is_none(), "{newer}");
    let sample = &newer["result"]["sample"];
    assert!(sample.is_object(), "{newer}");
    if sample["stoppedEarly"] == true {
        let ms = newer["result"]["stats"]["deriveMs"]
            .as_f64()
            .expect("deriveMs");
        assert!(
            ms >= 1400.0,
            "stopped after {ms} ms, before its budget: {newer}"
        );
    }
}

/// A grammar that cannot be previewed: answered 200 with the error, the
/// server's code and the document version whose text failed (the page
/// drops a failure about a text older than the one it shows).
#[test]
fn a_failed_preview_names_its_document_version() {
    let (_dir, _, server) = serve("broken.grm", "system Broken {\n    axiom F\n}\n");
    let addr = server.addr;
    let (_, uri) = first_events(addr);
    let (status, e) = post(
        addr,
        "/api/preview",
        &json!({ "textDocument": { "uri": uri } }),
    );
    assert_eq!(status, 200, "{e}");
    assert!(e["error"].is_string(), "{e}");
    assert!(e["code"].is_i64(), "{e}");
    assert!(e["version"].is_u64(), "{e}");
}

#[test]
fn serves_the_page_and_the_language_servers_preview() {
    let (_dir, grammar, server) = serve("koch.grm", KOCH);
    let addr = server.addr;

    let (status, page) = exchange(addr, &format!("GET / HTTP/1.1\r\nHost: {addr}\r\n\r\n"));
    assert_eq!(status, 200);
    assert!(page.as_str().is_some_and(|p| p.contains("preview.js")));
    let (status, _) = exchange(addr, "GET / HTTP/1.1\r\nHost: evil.example\r\n\r\n");
    assert_eq!(status, 403);
    // A second Host after this server's own is no way in.
    let (status, _) = exchange(
        addr,
        &format!("GET / HTTP/1.1\r\nHost: {addr}\r\nHost: evil.example\r\n\r\n"),
    );
    assert_eq!(status, 400);
    // The page comes with its content security policy, in the header and in its slot.
    let (head, html) = exchange_raw(addr, &format!("GET / HTTP/1.1\r\nHost: {addr}\r\n\r\n"));
    assert!(
        head.contains(&format!(
            "\r\nContent-Security-Policy: {CSP}; frame-ancestors 'none'\r\n"
        )),
        "{head}"
    );
    assert!(!html.contains("<!--CSP-->"), "the placeholder is left in");
    assert!(
        html.contains(&format!(
            "<meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">"
        )),
        "{html}"
    );
    assert!(CSP.contains("script-src 'self';") && !CSP.contains("unsafe-eval"));

    // The document event names the URI the page must use.
    let (ev, uri) = first_events(addr);
    assert_eq!(ev["events"][0]["method"], "document");

    let (status, r) = post(
        addr,
        "/api/preview",
        &json!({ "textDocument": { "uri": uri }, "live": true }),
    );
    assert_eq!(status, 200, "{r}");
    let result = &r["result"];
    assert_eq!(result["system"], "Koch");
    assert_eq!(result["encoding"], "base64-le");
    // Koch island, 2 iterations: 4 * 8^2 = 256 segments, one bone each.
    assert_eq!(result["skeleton"]["boneCount"], 256);
    assert!(result["stats"]["triangles"].as_u64().is_some_and(|t| t > 0));

    // API answers say how long the server took (Server-Timing).
    let body = json!({ "textDocument": { "uri": uri }, "live": true }).to_string();
    let (head, _) = exchange_raw(
        addr,
        &format!(
            "POST /api/preview HTTP/1.1\r\nHost: {addr}\r\nContent-Length: {}\r\n\r\n{body}",
            body.len()
        ),
    );
    let dur: f64 = head
        .lines()
        .find_map(|l| l.strip_prefix("Server-Timing: app;dur="))
        .and_then(|d| d.parse().ok())
        .unwrap_or_else(|| panic!("no Server-Timing in {head}"));
    assert!(dur.is_finite() && dur >= 0.0, "{head}");
    let (page_head, _) = exchange_raw(addr, &format!("GET / HTTP/1.1\r\nHost: {addr}\r\n\r\n"));
    assert!(!page_head.contains("Server-Timing"), "{page_head}");

    let (status, p) = post(
        addr,
        "/api/pick",
        &json!({ "textDocument": { "uri": uri }, "bone": 0 }),
    );
    assert_eq!(status, 200, "{p}");
    assert_eq!(p["result"]["symbol"], "F");

    // The page's "Save picture": the same model, drawn as a PNG.
    let (status, p) = post(
        addr,
        "/api/picture",
        &json!({ "textDocument": { "uri": uri }, "width": 64, "height": 48 }),
    );
    assert_eq!(status, 200, "{p}");
    assert_eq!(
        (
            p["result"]["width"].as_u64(),
            p["result"]["height"].as_u64()
        ),
        (Some(64), Some(48))
    );
    assert_eq!(p["result"]["bones"], 256);
    let png = base64::Engine::decode(
        &base64::engine::general_purpose::STANDARD,
        p["result"]["png"].as_str().expect("png"),
    )
    .expect("base64");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");

    let (status, e) = post(
        addr,
        "/api/preview",
        &json!({ "textDocument": { "uri": "file:///etc/passwd" } }),
    );
    assert_eq!(status, 200);
    assert!(
        e["error"]
            .as_str()
            .is_some_and(|m| m.contains("not file:///etc/passwd"))
    );

    // Curves: none yet; an invalid file is refused, a valid one written.
    let (_, c) = post(addr, "/api/loadCurves", &json!({ "uri": uri }));
    assert_eq!(c["result"]["text"], Value::Null);
    let (status, e) = post(
        addr,
        "/api/saveCurves",
        &json!({ "uri": uri, "text": "{\"version\": 1, \"curves\": []}" }),
    );
    assert_eq!(status, 200, "{e}");
    assert!(e["error"].is_string(), "{e}");
    assert!(!curves_path_for(&grammar).exists());
    let curves = "{\"version\": 1, \"curves\": [{\"points\": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]]}]}";
    let (status, _) = post(
        addr,
        "/api/saveCurves",
        &json!({ "uri": uri, "text": curves }),
    );
    assert_eq!(status, 200);
    assert_eq!(
        std::fs::read_to_string(curves_path_for(&grammar))
            .ok()
            .as_deref(),
        Some(curves)
    );

    // The page's own save is not a change to report; a write by someone else is.
    std::thread::sleep(WATCH_EVERY * 3);
    let (_, quiet) = exchange(
        addr,
        &format!("GET /api/events?after=1&wait=0 HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
    );
    assert!(
        !quiet["events"]
            .as_array()
            .is_some_and(|es| es.iter().any(|e| e["method"] == "curvesChanged")),
        "{quiet}"
    );
    let mut after = quiet["seq"].as_u64().unwrap_or(1);
    std::fs::write(
        curves_path_for(&grammar),
        curves.replace("[0,3,0]", "[0,4,0]"),
    )
    .expect("write curves");
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        assert!(Instant::now() < deadline, "no curvesChanged");
        let (_, ev) = exchange(
            addr,
            &format!("GET /api/events?after={after} HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        after = ev["seq"].as_u64().unwrap_or(after);
        if ev["events"].as_array().is_some_and(|es| {
            es.iter()
                .any(|e| e["method"] == "curvesChanged" && e["params"]["uri"] == uri)
        }) {
            break;
        }
    }

    // An edit on disk reaches the page as the server's live preview.
    std::thread::sleep(Duration::from_millis(20));
    std::fs::write(
        &grammar,
        "system Koch {\n    iterations = 1;\n    angle = 90;\n    width = 0.1;\n    axiom F - F - F - F;\n    F -> F - F + F + F F - F - F + F;\n}\n",
    )
    .expect("write");
    let deadline = Instant::now() + Duration::from_secs(20);
    let updated = loop {
        assert!(Instant::now() < deadline, "no previewUpdated");
        let (_, ev) = exchange(
            addr,
            &format!("GET /api/events?after={after} HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        after = ev["seq"].as_u64().unwrap_or(after);
        if let Some(u) = ev["events"]
            .as_array()
            .and_then(|es| es.iter().find(|e| e["method"] == "previewUpdated"))
        {
            break u["params"].clone();
        }
    };
    assert_eq!(updated["result"]["skeleton"]["boneCount"], 32);
}

#[test]
fn a_drag_through_the_page_rewrites_the_file_and_regrows_the_preview() {
    let text = "system Bar {\n    iterations = 1;\n    axiom A;\n    A -> F(2) +(30) F(1);\n}\n";
    let (_dir, grammar, server) = serve("bar.grm", text);
    let addr = server.addr;
    let (ev, uri) = first_events(addr);
    let mut after = ev["seq"].as_u64().unwrap_or(0);
    let (status, r) = post(
        addr,
        "/api/preview",
        &json!({ "textDocument": { "uri": uri }, "live": true }),
    );
    assert_eq!(status, 200, "{r}");
    let (_, p) = post(
        addr,
        "/api/pick",
        &json!({ "textDocument": { "uri": uri }, "bone": 1 }),
    );
    let key = p["result"]["key"].clone();
    assert_eq!(key.as_str().map(str::len), Some(8), "{p}");
    // The second bone, 1 long, dragged along itself to 1.5.
    let bones = base64::Engine::decode(
        &base64::engine::general_purpose::STANDARD,
        r["result"]["skeleton"]["bones"].as_str().expect("bones"),
    )
    .expect("base64");
    let f = |i: usize| f32::from_le_bytes(bones[i * 4..i * 4 + 4].try_into().unwrap()) as f64;
    let (base, tip) = ([f(8), f(9), f(10)], [f(11), f(12), f(13)]);
    let at: Vec<f64> = (0..3).map(|i| base[i] + (tip[i] - base[i]) * 1.5).collect();
    let (status, d) = post(
        addr,
        "/api/drag",
        &json!({ "textDocument": { "uri": uri }, "part": { "kind": "bone", "key": key },
                 "target": { "kind": "tip", "at": at } }),
    );
    assert_eq!(status, 200, "{d}");
    assert_eq!(d["result"]["outcome"], "solved", "{d}");
    assert_eq!(d["result"]["written"], true, "{d}");
    assert!(d["result"].get("text").is_none());
    let on_disk = std::fs::read_to_string(&grammar).expect("read");
    assert!(on_disk.contains("A -> F(2) +(30) F(1.5);"), "{on_disk}");
    // The live preview regrows from the written text.
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        assert!(Instant::now() < deadline, "no previewUpdated");
        let (_, ev) = exchange(
            addr,
            &format!("GET /api/events?after={after} HTTP/1.1\r\nHost: {addr}\r\n\r\n"),
        );
        after = ev["seq"].as_u64().unwrap_or(after);
        if ev["events"]
            .as_array()
            .is_some_and(|es| es.iter().any(|e| e["method"] == "previewUpdated"))
        {
            break;
        }
    }
}

/// Protocol 3 over HTTP: a preview asked with `binary` names a blob
/// that `GET /api/blob/ID` serves, and each buffer read from it is the
/// base64 answer's; an unknown blob is 404.
#[test]
fn a_binary_previews_blob_holds_the_base64_previews_buffers() {
    use grm_lsp::blob::Buf;
    let (_dir, _, server) = serve("koch.grm", KOCH);
    let addr = server.addr;
    let (_, uri) = first_events(addr);
    let (_, text) = post(
        addr,
        "/api/preview",
        &json!({ "textDocument": { "uri": uri } }),
    );
    let (_, bin) = post(
        addr,
        "/api/preview",
        &json!({ "textDocument": { "uri": uri }, "binary": true }),
    );
    let (text, bin) = (&text["result"], &bin["result"]);
    assert_eq!(text["encoding"], "base64-le");
    assert_eq!(bin["encoding"], "blob-le", "{bin}");
    let id = bin["blob"]["id"].as_u64().expect("blob id");
    let mut s = TcpStream::connect(addr).expect("connect");
    s.write_all(format!("GET /api/blob/{id} HTTP/1.1\r\nHost: {addr}\r\n\r\n").as_bytes())
        .expect("send");
    let mut out = Vec::new();
    s.read_to_end(&mut out).expect("read");
    let at = out.windows(4).position(|w| w == b"\r\n\r\n").expect("head") + 4;
    let head = String::from_utf8_lossy(&out[..at]);
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    assert!(head.contains("application/octet-stream"), "{head}");
    let blob = &out[at..];
    assert_eq!(Some(blob.len() as u64), bin["blob"]["bytes"].as_u64());
    let buf = |v: &Value| serde_json::from_value::<Buf>(v.clone()).expect("a buffer");
    let mut compared = 0;
    let (tp, bp) = (
        text["parts"].as_array().expect("parts"),
        bin["parts"].as_array().expect("parts"),
    );
    assert_eq!(tp.len(), bp.len());
    for (a, b) in tp.iter().zip(bp) {
        for k in ["positions", "normals", "indices", "picks"] {
            assert_eq!(buf(&a[k]).decode(&[]), buf(&b[k]).decode(blob), "{k}");
            compared += 1;
        }
    }
    for k in ["bones", "parents", "origins"] {
        let (a, b) = (&text["skeleton"][k], &bin["skeleton"][k]);
        assert!(b.is_object(), "{k}: a range");
        assert_eq!(buf(a).decode(&[]), buf(b).decode(blob), "{k}");
        compared += 1;
    }
    assert!(compared > 3);
    let (status, _) = exchange(
        addr,
        &format!(
            "GET /api/blob/{} HTTP/1.1\r\nHost: {addr}\r\n\r\n",
            id + 100
        ),
    );
    assert_eq!(status, 404);
}

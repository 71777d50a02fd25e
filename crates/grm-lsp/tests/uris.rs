//! Document URIs in the client's own spelling. Editors spell the URI of one
//! file differently: VS Code percent-encodes nearly everything (and the
//! drive colon, `file:///c%3A/...`), others leave `+`, `:` or parentheses as
//! they are, or write lowercase hex. Whatever a client opened a document
//! under, every answer that names that document (diagnostics, definitions,
//! references, rename edits, previews) must carry that very string: clients
//! key their buffers by it, and a differently spelt URI is a different (or
//! unknown) document to them. Two spellings of one file are one document.

mod common;

use common::*;
use serde_json::{Value, json};
use std::collections::BTreeSet;
use std::path::PathBuf;
use tower_lsp_server::ls_types::Uri;

/// The file a `file:` URI names (as the server decodes it), to recognise a
/// notification about a file whatever spelling it carries.
fn file_of(uri: &str) -> Option<PathBuf> {
    let u: Uri = uri.parse().ok()?;
    u.to_file_path().map(|p| p.into_owned())
}

/// The next `publishDiagnostics` for the file `uri` names, in any spelling
/// (so that a wrong spelling fails the comparison, not the wait).
async fn diagnostics_for(c: &mut Client, uri: &str, pred: impl Fn(&Value) -> bool) -> Value {
    let want = file_of(uri);
    let r = c
        .wait_for(|r| {
            r.method() == "textDocument/publishDiagnostics"
                && r.params()
                    .is_some_and(|p| p["uri"].as_str().and_then(file_of) == want && pred(p))
        })
        .await;
    r.params().cloned().unwrap_or(Value::Null)
}

fn codes(d: &Value) -> Vec<String> {
    d["diagnostics"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|d| d["code"].as_str().unwrap_or("-").to_string())
                .collect()
        })
        .unwrap_or_default()
}

/// The URIs of a list of locations (or of symbols' locations).
fn uris_of(locs: &Value) -> BTreeSet<String> {
    locs.as_array()
        .map(|a| {
            a.iter()
                .filter_map(|l| {
                    l["uri"]
                        .as_str()
                        .or_else(|| l["location"]["uri"].as_str())
                        .map(str::to_string)
                })
                .collect()
        })
        .unwrap_or_default()
}

fn with_name(mut params: Value, name: &str) -> Value {
    params["newName"] = json!(name);
    params
}

/// Spellings of document URIs as editors send them. On Windows the first
/// two are one file; elsewhere `/c:/...` is just an odd directory name.
const SPELLINGS: &[&str] = &[
    // VS Code on Windows: lowercase drive, encoded colon and spaces.
    "file:///c%3A/Users/x/My%20Grammars/tree.grm",
    // Other clients: the drive colon as it is.
    "file:///C:/Users/x/My%20Grammars/tree.grm",
    // `+`, encoded (VS Code) and not (most other clients).
    "file:///home/x/a%2Bb.grm",
    "file:///home/x/a+b.grm",
    // Lowercase hex digits.
    "file:///home/x/a%2bb.grm",
    // Non-ASCII names, percent-encoded UTF-8, upper and lower case hex.
    "file:///home/x/Gr%C3%BC%C3%9Fe/%E6%A8%B9.grm",
    "file:///home/x/gr%c3%bc%c3%9fe/caf%c3%a9.grm",
    // Sub-delimiters a client need not encode.
    "file:///home/x/v1(copy)%20&%20more,final!.grm",
    // An explicit empty-path authority.
    "file://localhost/home/x/tree.grm",
];

const TREE: &str =
    "const ratio = 0.9;\nsystem S {\n    axiom A(1);\n    A(l) -> F(l) A(l * rato * ratio);\n}\n";

/// Diagnostics, definitions, references and rename edits of a document
/// name it by the URI it was opened under, for each spelling.
#[tokio::test]
async fn answers_name_a_document_by_the_uri_it_was_opened_under() {
    for &spelling in SPELLINGS {
        let mut c = Client::start().await;
        let u = c.open_as(spelling, TREE).await;
        let d = diagnostics_for(&mut c, spelling, |_| true).await;
        assert_eq!(d["uri"], spelling, "publishDiagnostics");
        assert_eq!(codes(&d), ["E0101"], "{d}");

        let def = c
            .ok("textDocument/definition", at(&u, pos(TREE, "ratio)", 0, 0)))
            .await;
        assert_eq!(def["uri"], spelling, "definition: {def}");
        assert_eq!(range_str(&def["range"]), "0:6-0:11");

        let mut params = at(&u, pos(TREE, "ratio)", 0, 0));
        params["context"] = json!({ "includeDeclaration": true });
        let refs = c.ok("textDocument/references", params).await;
        assert_eq!(
            uris_of(&refs),
            BTreeSet::from([spelling.to_string()]),
            "references: {refs}"
        );
        assert_eq!(refs.as_array().map(Vec::len), Some(2));

        let edit = c
            .ok(
                "textDocument/rename",
                with_name(at(&u, pos(TREE, "ratio)", 0, 0)), "scale"),
            )
            .await;
        let keys: Vec<&String> = edit["changes"]
            .as_object()
            .map(|m| m.keys().collect())
            .unwrap_or_default();
        assert_eq!(keys, [spelling], "rename: {edit}");

        // The quick fix for `rato` edits the same document.
        let fix = c
            .ok(
                "textDocument/codeAction",
                json!({
                    "textDocument": { "uri": spelling },
                    "range": { "start": pos(TREE, "rato ", 0, 0), "end": pos(TREE, "rato ", 0, 4) },
                    "context": { "diagnostics": [] }
                }),
            )
            .await;
        let fix_keys: BTreeSet<&String> = fix
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|a| a["edit"]["changes"].as_object())
            .flat_map(|m| m.keys())
            .collect();
        assert_eq!(fix_keys, BTreeSet::from([&spelling.to_string()]), "{fix}");

        // Closing clears the diagnostics under the same URI.
        c.notify(
            "textDocument/didClose",
            json!({ "textDocument": { "uri": spelling } }),
        )
        .await;
        let cleared = diagnostics_for(&mut c, spelling, |p| {
            p["diagnostics"].as_array().is_some_and(Vec::is_empty)
        })
        .await;
        assert_eq!(cleared["uri"], spelling);
    }
}

/// A request that names an open document in another spelling of its URI
/// is about the same document, and the answer still uses the spelling the
/// document was opened under.
#[tokio::test]
async fn another_spelling_of_an_open_document_is_the_same_document() {
    let mut c = Client::start().await;
    // Opened with `+` as it is; asked about with `+` encoded.
    let opened = "file:///home/x/My%20Grammars/a+b.grm";
    let other = "file:///home/x/My%20Grammars/a%2bb.grm";
    let _ = c.open_as(opened, TREE).await;
    let d = diagnostics_for(&mut c, opened, |_| true).await;
    assert_eq!(d["uri"], opened);
    let def = c
        .ok(
            "textDocument/definition",
            json!({ "textDocument": { "uri": other }, "position": pos(TREE, "ratio)", 0, 0) }),
        )
        .await;
    assert_eq!(def["uri"], opened, "{def}");
    // An edit sent under the other spelling edits the open document.
    c.notify(
        "textDocument/didChange",
        json!({
            "textDocument": { "uri": other, "version": 2 },
            "contentChanges": [ { "text": TREE.replace("rato", "ratio") } ]
        }),
    )
    .await;
    let d = diagnostics_for(&mut c, opened, |p| p["version"] == 2).await;
    assert_eq!(d["uri"], opened);
    assert_eq!(codes(&d), Vec::<String>::new(), "{d}");
}

const LIB: &str = "// Shared constants.\nconst GOLDEN = 0.618;\n";
const PLANT: &str =
    "import \"lib+v2.grm\";\nsystem Plant {\n    axiom A(1);\n    A(l) -> F(l * GOLDEN) A(l);\n}\n";

/// Two open documents with encoded URIs, one importing the other (neither
/// exists on disk): the import is the open buffer, and each file's
/// diagnostics, definitions, references and edits carry its own URI.
#[tokio::test]
async fn an_import_between_open_documents_keeps_each_uri() {
    // The drive colon and the spaces encoded, `+` in lowercase hex.
    let lib = "file:///c%3A/Users/x/My%20Grammars/lib%2bv2.grm";
    let plant = "file:///c%3A/Users/x/My%20Grammars/pl%C3%A4nt.grm";
    let mut c = Client::start().await;
    let lu = c.open_as(lib, LIB).await;
    let pu = c.open_as(plant, PLANT).await;
    let d = diagnostics_for(&mut c, plant, |_| true).await;
    assert_eq!(d["uri"], plant);
    // The import resolved to the open buffer (the file is not on disk).
    assert_eq!(codes(&d), Vec::<String>::new(), "{d}");
    let d = diagnostics_for(&mut c, lib, |_| true).await;
    assert_eq!(d["uri"], lib);

    // Definition in the imported file: the imported file's URI.
    let def = c
        .ok(
            "textDocument/definition",
            at(&pu, pos(PLANT, "GOLDEN", 0, 0)),
        )
        .await;
    assert_eq!(def["uri"], lib, "{def}");
    // The import path leads to the imported file too.
    let def = c
        .ok(
            "textDocument/definition",
            at(&pu, pos(PLANT, "lib+v2", 0, 1)),
        )
        .await;
    assert_eq!(def["uri"], lib, "{def}");

    // References and rename from the imported file reach the importer.
    let mut params = at(&lu, pos(LIB, "GOLDEN", 0, 0));
    params["context"] = json!({ "includeDeclaration": true });
    let refs = c.ok("textDocument/references", params).await;
    assert_eq!(
        uris_of(&refs),
        BTreeSet::from([lib.to_string(), plant.to_string()]),
        "{refs}"
    );
    let edit = c
        .ok(
            "textDocument/rename",
            with_name(at(&lu, pos(LIB, "GOLDEN", 0, 0)), "PHI"),
        )
        .await;
    let keys: BTreeSet<&String> = edit["changes"]
        .as_object()
        .map(|m| m.keys().collect())
        .unwrap_or_default();
    assert_eq!(
        keys,
        BTreeSet::from([&lib.to_string(), &plant.to_string()]),
        "{edit}"
    );

    // Breaking the imported file re-publishes the importer under its URI.
    c.notify(
        "textDocument/didChange",
        json!({
            "textDocument": { "uri": lib, "version": 2 },
            "contentChanges": [ { "text": LIB.replace("GOLDEN", "GOLDEQ") } ]
        }),
    )
    .await;
    let d = diagnostics_for(&mut c, plant, |p| {
        p["diagnostics"]
            .as_array()
            .is_some_and(|a| a.iter().any(|d| d["code"] == "E0101"))
    })
    .await;
    assert_eq!(d["uri"], plant, "{d}");

    // A definition of the importer that clashes with the imported one: the
    // related label ("first defined here") is in the imported file.
    c.notify(
        "textDocument/didChange",
        json!({
            "textDocument": { "uri": plant, "version": 2 },
            "contentChanges": [ { "text": format!("{PLANT}const GOLDEQ = 1;\n") } ]
        }),
    )
    .await;
    let d = diagnostics_for(&mut c, plant, |p| p["version"] == 2).await;
    assert_eq!(d["uri"], plant);
    let dup = d["diagnostics"]
        .as_array()
        .and_then(|a| a.iter().find(|d| d["code"] == "E0102"))
        .cloned()
        .unwrap_or_else(|| panic!("E0102 expected: {d}"));
    let related: BTreeSet<String> = dup["relatedInformation"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|r| r["location"]["uri"].as_str().map(str::to_string))
        .collect();
    assert_eq!(related, BTreeSet::from([lib.to_string()]), "{dup}");
}

const PREVIEWED: &str = "import \"lib+v2.grm\";\nsystem Plant {\n    iterations = 2;\n    axiom A(1);\n    A(l) -> F(l * GOLDEN) A(l);\n}\n";

/// The preview extension: `grm/preview`'s result, its origins, `grm/pick`
/// and `grm/previewUpdated` carry the client's URIs; origins in an
/// imported file carry the imported file's.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn previews_carry_the_clients_uris() {
    let lib_text = "const GOLDEN = 0.618;\nsystem Lib {\n    iterations = 2;\n    axiom B;\n    B -> F B;\n}\n";
    let lib = "file:///c%3A/Users/x/My%20Grammars/lib+v2.grm";
    let plant = "file:///c%3A/Users/x/My%20Grammars/%E6%A8%B9.grm";
    let mut c = Client::start().await;
    let _ = c.open_as(lib, lib_text).await;
    let _ = c.open_as(plant, PREVIEWED).await;
    let _ = diagnostics_for(&mut c, plant, |_| true).await;

    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": plant }, "system": "Plant", "live": true }),
        )
        .await;
    assert_eq!(r["uri"], plant);
    assert_eq!(uris_of(&r["origins"]), BTreeSet::from([plant.to_string()]));
    let pk = c
        .ok(
            "grm/pick",
            json!({ "textDocument": { "uri": plant }, "bone": 0 }),
        )
        .await;
    assert_eq!(pk["uri"], plant, "{pk}");

    // A system of the imported file, previewed from the importer: its
    // origins are in the imported file.
    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": plant }, "system": "Lib", "live": true }),
        )
        .await;
    assert_eq!(r["uri"], plant);
    assert_eq!(uris_of(&r["origins"]), BTreeSet::from([lib.to_string()]));

    // A live update after an edit.
    c.notify(
        "textDocument/didChange",
        json!({
            "textDocument": { "uri": plant, "version": 2 },
            "contentChanges": [ { "text": PREVIEWED.replace("iterations = 2", "iterations = 3") } ]
        }),
    )
    .await;
    let up = c
        .wait_for(|r| {
            r.method() == "grm/previewUpdated" && r.params().is_some_and(|p| p["version"] == 2)
        })
        .await;
    let p = up.params().cloned().unwrap_or(Value::Null);
    assert_eq!(p["uri"], plant, "{p}");
    assert_eq!(p["result"]["uri"], plant);
    assert_eq!(
        uris_of(&p["result"]["origins"]),
        BTreeSet::from([lib.to_string()])
    );
}

/// Files of the workspace that are not open are named under the workspace
/// folder as the client spelt it (so the client recognises them as the
/// documents it would open), and a file that is then opened under another
/// spelling is named by that one.
#[cfg(unix)] // the folder's URI is written from a Unix path
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn workspace_files_are_named_under_the_clients_folder_uri() {
    let dir = std::env::temp_dir().join(format!("grm lsp+uris é {}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("lib.grm"), LIB).expect("write");
    std::fs::write(
        dir.join("user.grm"),
        "import \"lib.grm\";\nconst TWICE = GOLDEN * 2;\n",
    )
    .expect("write");
    // The folder as a client might spell it: lowercase hex, `+` as it is.
    let mut folder = String::from("file://");
    for b in dir.to_string_lossy().bytes() {
        match b {
            b'+' | b'/' | b'-' | b'.' | b'_' | b'~' => folder.push(b as char),
            b if b.is_ascii_alphanumeric() => folder.push(b as char),
            b => folder.push_str(&format!("%{b:02x}")),
        }
    }
    let mut c = Client::with_init(
        grm_lsp::Config::default(),
        json!({
            "capabilities": {},
            "workspaceFolders": [ { "uri": folder, "name": "w" } ]
        }),
    )
    .await;
    let r = c.ok("workspace/symbol", json!({ "query": "twice" })).await;
    assert_eq!(
        uris_of(&r),
        BTreeSet::from([format!("{folder}/user.grm")]),
        "{r}"
    );
    // Open lib.grm (in yet another spelling): references reach user.grm,
    // which is not open, under the folder's spelling.
    let lib = format!("{}/lib.grm", folder.replace('+', "%2B"));
    let lu = c.open_as(&lib, LIB).await;
    let mut params = at(&lu, pos(LIB, "GOLDEN", 0, 0));
    params["context"] = json!({ "includeDeclaration": true });
    let refs = c.ok("textDocument/references", params).await;
    assert_eq!(
        uris_of(&refs),
        BTreeSet::from([lib.clone(), format!("{folder}/user.grm")]),
        "{refs}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Percent-encoded bytes that are not UTF-8 name distinct files on Unix:
/// they must not be decoded lossily into one document.
#[cfg(unix)]
#[tokio::test]
async fn non_utf8_file_names_are_distinct_documents() {
    let a = "file:///home/x/%FF.grm";
    let b = "file:///home/x/%FE.grm";
    let mut c = Client::start().await;
    let _ = c.open_as(a, TREE).await;
    let _ = c.open_as(b, &TREE.replace("rato", "ratio")).await;
    let mut got = Vec::new();
    for _ in 0..2 {
        let r = c
            .wait_for(|r| r.method() == "textDocument/publishDiagnostics")
            .await;
        let p = r.params().cloned().unwrap_or(Value::Null);
        got.push((p["uri"].as_str().unwrap_or("").to_string(), codes(&p)));
    }
    got.sort();
    assert_eq!(
        got,
        [
            (b.to_string(), Vec::<String>::new()),
            (a.to_string(), vec!["E0101".to_string()]),
        ]
    );
}

/// A raw space or non-ASCII character makes a string no URI (RFC 3986):
/// the protocol library refuses the message before the server sees it (a
/// request is answered InvalidParams, a notification dropped). The server
/// stays up and serves the same file under its encoded URI.
#[tokio::test]
async fn an_invalid_uri_is_refused_without_harm() {
    let mut c = Client::start().await;
    for raw in [
        "file:///home/x/My Grammars/tree.grm",
        "file:///home/x/Gr\u{fc}\u{df}e/tree.grm",
    ] {
        c.notify(
            "textDocument/didOpen",
            json!({ "textDocument": { "uri": raw, "languageId": "grm", "version": 1, "text": TREE } }),
        )
        .await;
        let e = c
            .request(
                "textDocument/hover",
                json!({ "textDocument": { "uri": raw }, "position": { "line": 0, "character": 6 } }),
            )
            .await
            .expect_err("not a URI");
        assert_eq!(e["code"], -32602, "{e}");
    }
    let encoded = "file:///home/x/My%20Grammars/tree.grm";
    let _ = c.open_as(encoded, TREE).await;
    let d = diagnostics_for(&mut c, encoded, |_| true).await;
    assert_eq!(d["uri"], encoded);
    assert_eq!(codes(&d), ["E0101"]);
}

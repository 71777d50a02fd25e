//! The mistakes a new user makes, and the commands of the README, as a
//! user runs them: exit codes, messages, and nothing done before a usage
//! problem is reported.

use std::path::Path;
use std::process::Command;

mod common;
use common::*;

fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// README: `grmc derive examples/koch_island.grm --stats -o koch.svg`.
#[test]
fn readme_derive_with_stats_writes_an_svg() {
    let dir = tempfile::tempdir().expect("tempdir");
    let svg = dir.path().join("koch.svg");
    let out = grmc(&[
        "derive",
        &example("koch_island.grm"),
        "--stats",
        "-o",
        path(&svg),
    ]);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    // The header and one row per string (the axiom and 3 iterations).
    assert!(stdout.starts_with("iteration"), "{stdout}");
    assert_eq!(stdout.lines().count(), 5, "{stdout}");
    assert!(
        stderr.contains("KochIsland: 3 iterations: 3803 modules (4337 produced in all)"),
        "{stderr}"
    );
    // An SVG holds lines and polygons, not triangles: the note counts those.
    let lines = stderr
        .lines()
        .find(|l| l.starts_with("wrote "))
        .unwrap_or_else(|| panic!("no `wrote` line: {stderr}"));
    let written = std::fs::read_to_string(&svg).expect("svg written");
    assert!(written.starts_with("<?xml"), "{written:.80}");
    assert!(written.contains("<svg"));
    let drawn = written.matches("<line ").count();
    assert!(
        lines.ends_with(&format!("({drawn} lines, 0 polygons)")),
        "{lines}"
    );
}

/// A file that could not be read was not checked: the summary must not
/// count it as a clean file.
#[test]
fn check_summary_counts_unreadable_files_apart() {
    let out = grmc(&["check", "/nonexistent/x.grm"]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("cannot read /nonexistent/x.grm"), "{err}");
    assert!(
        err.contains("checked 0 files: 0 errors, 0 warnings; 1 could not be read"),
        "{err}"
    );
    let out = grmc(&["check", &example("koch_island.grm"), "/nonexistent/x.grm"]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("checked 1 file: 0 errors, 0 warnings; 1 could not be read"),
        "{err}"
    );
}

/// `grmc fmt` on a file with syntax errors shows them like `grmc check`
/// (code, file:line:column, the source), not as byte offsets.
#[test]
fn fmt_renders_syntax_errors_as_diagnostics() {
    let dir = tempfile::tempdir().expect("tempdir");
    let f = dir.path().join("broken.grm");
    std::fs::write(&f, "system S { A -> ( ; }").expect("write");
    for flag in [None, Some("--check"), Some("--stdout")] {
        let mut args = vec!["fmt"];
        args.extend(flag);
        args.push(path(&f));
        let out = grmc(&args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flag:?}: {err}");
        assert!(err.contains("[E0001] Error: unexpected `;`"), "{err}");
        assert!(err.contains("broken.grm:1:19"), "{err}");
        assert!(
            err.contains("was not formatted: it has 1 syntax error\n"),
            "{err}"
        );
        assert!(!err.contains("at bytes"), "{err}");
        assert!(!err.contains("not formatted: not formatted"), "{err}");
    }
    assert_eq!(
        std::fs::read_to_string(&f).expect("read"),
        "system S { A -> ( ; }"
    );
}

/// Invalid UTF-8 is an input error with the checker's code, and the file
/// is left alone.
#[test]
fn fmt_reports_invalid_utf8_with_its_code() {
    let dir = tempfile::tempdir().expect("tempdir");
    let f = dir.path().join("latin1.grm");
    let bytes = b"system S { axiom \xff A; }\n";
    std::fs::write(&f, bytes).expect("write");
    let out = grmc(&["fmt", path(&f)]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("[E0404]"), "{err}");
    assert!(err.contains("latin1.grm:1:18"), "{err}");
    assert_eq!(std::fs::read(&f).expect("read"), bytes);
}

/// `grmc check` on a file that is not UTF-8: the one E0404, not also an
/// E0003 "invalid character" on the replacement character.
#[test]
fn check_reports_invalid_utf8_once() {
    let dir = tempfile::tempdir().expect("tempdir");
    let f = dir.path().join("latin1.grm");
    std::fs::write(&f, b"system S { axiom \xff F; }\n").expect("write");
    let out = grmc(&["check", "--format", "json", path(&f)]);
    let json = text(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    assert_eq!(json.matches("\"code\"").count(), 1, "{json}");
    assert!(json.contains("\"E0404\""), "{json}");
}

/// One unreadable file does not stop the others from being formatted; the
/// exit code still says something went wrong.
#[test]
fn fmt_goes_on_after_an_unreadable_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let f = dir.path().join("messy.grm");
    std::fs::write(&f, "system   S{axiom A;\nA->F   A;}\n").expect("write");
    let out = grmc(&["fmt", "/nonexistent/x.grm", path(&f)]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("cannot read /nonexistent/x.grm"), "{err}");
    let formatted = std::fs::read_to_string(&f).expect("read");
    assert_eq!(formatted, "system S {\n    axiom A;\n    A -> F A;\n}\n");
}

/// `grmc derive` on a `mode = sample` system says to use `grmc sample`
/// instead of rewriting it into an empty model.
#[test]
fn derive_refuses_a_sample_system() {
    let dir = tempfile::tempdir().expect("tempdir");
    let glb = dir.path().join("tree.glb");
    let out = grmc(&["derive", &example("calder_tree.grm"), "-o", path(&glb)]);
    let err = text(&out.stderr);
    // R0210, an input error like `grmc sample`'s R0301 on a derive system.
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("[R0210]") && err.contains("`CalderTree` is a sample system"),
        "{err}"
    );
    assert!(err.contains("calder_tree.grm"), "{err}");
    assert!(err.contains("grow it with `grmc sample`"), "{err}");
    assert!(!glb.exists());
    // The same file is what `grmc disasm` shows.
    let out = grmc(&["disasm", &example("calder_tree.grm")]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
}

/// `-o` into a directory that does not exist is R0407 before any work:
/// no derivation summary, no sampling report.
#[test]
fn output_into_a_missing_directory_fails_first() {
    let dir = tempfile::tempdir().expect("tempdir");
    let missing = dir.path().join("no-such-dir").join("koch.glb");
    let out = grmc(&["derive", &example("koch_island.grm"), "-o", path(&missing)]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("[R0407] Error: cannot write "), "{err}");
    assert!(err.contains("No such file or directory"), "{err}");
    assert!(!err.contains("modules ("), "derived before failing: {err}");

    // A file where the directory should be.
    let file = dir.path().join("plain");
    std::fs::write(&file, "").expect("write");
    let under = file.join("koch.glb");
    let out = grmc(&["derive", &example("koch_island.grm"), "-o", path(&under)]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("is not a directory"), "{err}");

    let out = grmc(&[
        "sample",
        &example("calder_tree.grm"),
        "--generations",
        "2",
        "-o",
        path(&missing),
    ]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("[R0407]"), "{err}");
    assert!(out.stdout.is_empty(), "sampled before failing");

    // A bare file name is written into the current directory.
    let out = Command::new(env!("CARGO_BIN_EXE_grmc"))
        .args([
            "derive",
            &example("koch_island.grm"),
            "-n",
            "1",
            "-o",
            "k.ply",
        ])
        .current_dir(dir.path())
        .output()
        .expect("grmc runs");
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(dir.path().join("k.ply").exists());
}

/// Absurd thread counts are refused by the argument parser; tens of
/// thousands of threads used to panic inside the thread pool.
#[test]
fn threads_are_capped() {
    let koch = example("koch_island.grm");
    let tree = example("calder_tree.grm");
    for args in [
        vec!["derive", koch.as_str(), "-n", "1", "--threads", "100000"],
        vec!["sample", tree.as_str(), "--threads", "100000"],
        vec!["bench", "derive", "--threads", "100000"],
        vec!["bench", "gpu", "--threads", "100000"],
    ] {
        let out = grmc(&args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("more than the 1024"), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    let out = grmc(&["derive", &koch, "-n", "1", "--threads", "3"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
}

/// A misspelt `--scene` is an error naming the scenes, not an empty table.
/// (`bench gpu` checks the names before it looks for a GPU.)
#[test]
fn bench_refuses_unknown_scenes() {
    for what in ["derive", "gpu"] {
        let out = grmc(&["bench", what, "--scene", "koch", "--runs", "1"]);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{what}: {err}");
        assert!(err.contains("unknown scene `koch`"), "{what}: {err}");
        assert!(err.contains("koch_island"), "{what}: {err}");
        assert!(out.stdout.is_empty(), "{what}: {}", text(&out.stdout));
    }
}

/// Counts of one read as English.
#[test]
fn counts_of_one_are_singular() {
    let out = grmc(&["derive", &example("koch_island.grm"), "-n", "1"]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("KochIsland: 1 iteration: 59 modules"), "{err}");
    let out = grmc(&[
        "sample",
        &example("calder_tree.grm"),
        "--generations",
        "1",
        "--candidates",
        "1",
    ]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(
        stdout.contains("CalderTree: seed 1, 1 generation, ") && stdout.contains(", 1 candidate, "),
        "{stdout}"
    );
}

/// `grmc --help` names both benchmarks.
#[test]
fn help_names_both_benchmarks() {
    let out = grmc(&["--help"]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0));
    assert!(
        stdout.contains("`grmc bench derive`, `grmc bench gpu`"),
        "{stdout}"
    );
    for sub in [
        "check", "fmt", "lsp", "view", "derive", "sample", "disasm", "bench",
    ] {
        let out = grmc(&[sub, "--help"]);
        assert_eq!(out.status.code(), Some(0), "{sub}");
        assert!(text(&out.stdout).contains("Usage: grmc "), "{sub}");
    }
}

/// Flags that size a derivation or a search are held to the bounds of the
/// settings they override (usage errors, exit 2, before anything runs).
#[test]
fn iteration_generation_and_particle_flags_are_bounded() {
    let koch = example("koch_island.grm");
    let calder = example("calder_tree.grm");
    for (args, want) in [
        (
            vec!["derive", koch.as_str(), "-n", "100001"],
            "100001 is not in 0..=100000",
        ),
        (
            vec!["sample", calder.as_str(), "--generations", "4000000000"],
            "is not in 1..=100000",
        ),
        // Zero of what a search needs at least one of is refused, not
        // quietly run as one.
        (
            vec!["sample", calder.as_str(), "--generations", "0"],
            "0 is not in 1..=100000",
        ),
        (
            vec!["sample", calder.as_str(), "--candidates", "0"],
            "0 is not in 1..",
        ),
        (
            vec!["sample", calder.as_str(), "--max-step-expansions", "0"],
            "0 is not in 1..",
        ),
        (
            vec!["sample", calder.as_str(), "--best", "0"],
            "`0` is not a whole number >= 1",
        ),
        // Negative numbers are values out of range, not unknown flags.
        (
            vec!["derive", koch.as_str(), "-n", "-1"],
            "-1 is not in 0..=100000",
        ),
        (
            vec!["sample", calder.as_str(), "--seed", "-1"],
            "-1 is not in 0..=4294967295",
        ),
        (
            vec!["sample", calder.as_str(), "--heuristic-scale", "-1"],
            "`-1` is not a finite number >= 0",
        ),
        (
            vec!["sample", calder.as_str(), "--particles", "1..100001"],
            "`100001` is not a whole number from 1 to 100000",
        ),
    ] {
        let out = grmc(&args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
    }
}

/// The README's command table names every option of every subcommand, so
/// a new flag cannot ship undocumented there (the flags are read from
/// `grmc COMMAND --help`, the table row from the README).
#[test]
fn readme_command_table_lists_every_flag() {
    let readme = std::fs::read_to_string(common::repo().join("README.md")).expect("README");
    for cmd in [
        "check",
        "fmt",
        "derive",
        "disasm",
        "sample",
        "view",
        "lsp",
        "edits check",
    ] {
        let args: Vec<&str> = cmd.split(' ').chain(["--help"]).collect();
        let help = common::text(&common::grmc(&args).stdout);
        // `grmc edits check|list` shares one row.
        let prefix = match cmd {
            "edits check" => "| `grmc edits check\\|list".to_owned(),
            _ => format!("| `grmc {cmd}"),
        };
        let row = readme
            .lines()
            .find(|l| l.starts_with(&prefix))
            .unwrap_or_else(|| panic!("README has no row for `grmc {cmd}`"));
        let usage = row.split(" | ").next().unwrap_or(row);
        let flags: Vec<&str> = help
            .split(|c: char| c.is_whitespace() || c == ',' || c == '[' || c == ']')
            .filter(|w| w.starts_with("--") && w.len() > 2 && *w != "--help")
            .map(|w| w.split('=').next().unwrap_or(w))
            .collect();
        assert!(
            !flags.is_empty() || cmd == "disasm",
            "{cmd}: no flags read from\n{help}"
        );
        for f in flags {
            assert!(
                usage.contains(&format!("{f} "))
                    || usage.contains(&format!("{f}]"))
                    || usage.contains(&format!("{f}`"))
                    || usage.contains(&format!("{f}\\")),
                "README row of `grmc {cmd}` does not name `{f}`:\n{usage}"
            );
        }
    }
}

/// A report piped into a reader that stops early (`grmc ... | head`) ends
/// quietly with success: no "failed printing to stdout" panic.
#[test]
fn closed_stdout_ends_quietly() {
    use std::process::{Command, Stdio};
    // Over a pipe buffer (64 KiB) of JSON: 1024 run-together symbols of
    // ten drawing letters each, one W0011 each.
    let dir = tempfile::tempdir().expect("tempdir");
    let names: Vec<String> = (0..1024u32)
        .map(|i| {
            (0..10)
                .map(|b| if i >> b & 1 == 1 { 'F' } else { 'f' })
                .collect()
        })
        .collect();
    let src = format!("system S {{\n    axiom {};\n}}\n", names.join(" "));
    let file = dir.path().join("many.grm");
    std::fs::write(&file, src).expect("write");
    let mut child = Command::new(env!("CARGO_BIN_EXE_grmc"))
        .args(["check", "--format", "json", path(&file)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("grmc starts");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("grmc ends");
    let err = text(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(out.status.code(), Some(0), "{err}");
    // The same report, read to the end, is the whole array.
    let full = grmc(&["check", "--format", "json", path(&file)]);
    let json = text(&full.stdout);
    assert!(json.len() > 1 << 17, "{}", json.len());
    assert_eq!(json.matches("\"W0011\"").count(), 1024);
}

/// `derive --print` writes grm source text that reads back: vectors,
/// booleans, meshes and materials as written, so the printed string, pasted
/// back as an axiom, prints the same string again.
#[test]
fn printed_strings_read_back_as_an_axiom() {
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::copy(
        common::repo().join("examples/leaf.obj"),
        dir.path().join("leaf.obj"),
    )
    .expect("copy");
    let decls = "mesh leaf = \"leaf.obj\";\nmaterial bark { roughness = 0.5; }\n";
    let first = dir.path().join("grow.grm");
    std::fs::write(
        &first,
        format!(
            "{decls}system S {{\n    iterations = 3;\n    \
             axiom A(vec3(1, 2, 3), true) rotate(vec3(0, 0, 1), 30) mesh(leaf) material(bark);\n    \
             A(v, b) : b -> F(v.x / 3) [ + A(v * 0.5, !b) ] A(v, !b);\n    \
             A(v, b) -> ! (1.5) F(v.y) A(v, !b);\n}}\n"
        ),
    )
    .expect("write");
    let out = grmc(&["derive", path(&first), "--print"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let printed = text(&out.stdout).trim_end().to_string();
    assert!(
        printed.contains("vec3(") && printed.contains("false"),
        "{printed}"
    );
    assert!(printed.contains("mesh(leaf) material(bark)"), "{printed}");
    let again = dir.path().join("again.grm");
    std::fs::write(
        &again,
        format!("{decls}system S {{\n    iterations = 0;\n    module A(v: vec3, b: bool);\n    axiom {printed};\n}}\n"),
    )
    .expect("write");
    let out = grmc(&["derive", path(&again), "--print"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert_eq!(text(&out.stdout).trim_end(), printed);
}

/// `grmc lsp` started with piped stdin and stdout.
fn lsp_child() -> (
    std::process::Child,
    std::process::ChildStdin,
    std::io::BufReader<std::process::ChildStdout>,
) {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_grmc"))
        .arg("lsp")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("grmc lsp starts");
    let stdin = child.stdin.take().expect("stdin");
    let stdout = std::io::BufReader::new(child.stdout.take().expect("stdout"));
    (child, stdin, stdout)
}

/// An LSP message framed for the wire.
fn lsp_frame(body: &[u8]) -> Vec<u8> {
    let mut f = format!("Content-Length: {}\r\n\r\n", body.len()).into_bytes();
    f.extend_from_slice(body);
    f
}

/// The next message `grmc lsp` writes, as text.
fn lsp_read(stdout: &mut impl std::io::BufRead) -> String {
    let mut len = 0;
    let mut line = String::new();
    while stdout.read_line(&mut line).expect("read") > 2 {
        if let Some(n) = line.trim().strip_prefix("Content-Length: ") {
            len = n.parse().expect("a length");
        }
        line.clear();
    }
    let mut body = vec![0; len];
    stdout.read_exact(&mut body).expect("a message");
    String::from_utf8_lossy(&body).into_owned()
}

/// `grmc lsp` exits 0 after `shutdown` then `exit`, and 1 after an `exit`
/// with no `shutdown` before it (LSP's rule for the exit notification).
#[test]
fn lsp_exit_code_follows_shutdown() {
    use std::io::Write;
    let frame = |body: &str| lsp_frame(body.as_bytes());
    let init = r#"{"jsonrpc":"2.0","id":1,"method":"initialize","params":{"capabilities":{}}}"#;
    let shutdown = r#"{"jsonrpc":"2.0","id":2,"method":"shutdown"}"#;
    let exit = r#"{"jsonrpc":"2.0","method":"exit"}"#;
    for (requests, want) in [(vec![init, shutdown], 0), (vec![init], 1)] {
        let (mut child, mut stdin, mut stdout) = lsp_child();
        // Each request waits for its response, as a client does.
        for (id, m) in requests.iter().enumerate() {
            stdin.write_all(&frame(m)).expect("write");
            stdin.flush().expect("flush");
            while !lsp_read(&mut stdout).contains(&format!("\"id\":{}", id + 1)) {}
        }
        stdin.write_all(&frame(exit)).expect("write");
        drop(stdin);
        let status = child.wait().expect("grmc lsp ends");
        assert_eq!(status.code(), Some(want), "{requests:?}");
    }
}

/// `grmc lsp` answers malformed messages (bad JSON, wrong JSON-RPC, bad
/// framing, invalid UTF-8, deep nesting, a lone surrogate) with an error
/// and keeps serving; an `exit` ends it even while the client keeps its
/// end of stdin open.
#[test]
fn lsp_survives_malformed_messages() {
    use std::io::Write;
    let frame = lsp_frame;
    let (mut child, mut stdin, mut stdout) = lsp_child();
    let mut read = move || lsp_read(&mut stdout);
    let mut send = |bytes: &[u8]| {
        stdin.write_all(bytes).expect("write");
        stdin.flush().expect("flush");
    };
    send(&frame(
        br#"{"jsonrpc":"2.0","id":1,"method":"initialize","params":{"capabilities":{}}}"#,
    ));
    assert!(read().contains("\"id\":1"));
    send(&frame(
        br#"{"jsonrpc":"2.0","method":"initialized","params":{}}"#,
    ));
    let deep = "[".repeat(100_000);
    let bad: Vec<Vec<u8>> = vec![
        frame(b"{{{{{"),
        frame(b"[]"),
        frame(b"5"),
        frame(br#"{"jsonrpc":"1.0","id":3,"method":"shutdown"}"#),
        frame(br#"{"jsonrpc":"2.0","id":1.5,"method":"shutdown"}"#),
        frame(b"{\"jsonrpc\":\"2.0\",\"id\":4,\"method\":\"\xff\"}"),
        frame(deep.as_bytes()),
        b"Content-Length: abc\r\n\r\n".to_vec(),
    ];
    for (k, b) in bad.iter().enumerate() {
        send(b);
        let answer = read();
        assert!(
            answer.contains("\"error\"")
                && (answer.contains("-32700") || answer.contains("-32600")),
            "message {k}: {answer}"
        );
    }
    // A Content-Type header, LF-only lines, and a lone surrogate in a
    // document's text: all read.
    let uri = "file:///tmp/grm-lsp-survives.grm";
    let open = format!(
        r#"{{"jsonrpc":"2.0","method":"textDocument/didOpen","params":{{"textDocument":{{"uri":"{uri}","languageId":"grm","version":1,"text":"// \ud83c\nsystem S {{ axiom F; }}\n"}}}}}}"#
    );
    let mut f = format!(
        "Content-Length: {}\nContent-Type: application/vscode-jsonrpc; charset=utf-8\n\n",
        open.len()
    )
    .into_bytes();
    f.extend_from_slice(open.as_bytes());
    send(&f);
    let published = read();
    assert!(
        published.contains("publishDiagnostics") && published.contains(uri),
        "{published}"
    );
    // `"params": null` (Eglot, lsp4ij) and `{}` read as no params.
    send(&frame(
        br#"{"jsonrpc":"2.0","id":2,"method":"shutdown","params":null}"#,
    ));
    let answer = read();
    assert!(
        answer.contains("\"id\":2") && !answer.contains("error"),
        "{answer}"
    );
    // `exit` with stdin still open: the server ends anyway, with 0.
    send(&frame(br#"{"jsonrpc":"2.0","method":"exit","params":{}}"#));
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        assert!(start.elapsed().as_secs() < 20, "grmc lsp did not exit");
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert_eq!(status.code(), Some(0));
}

/// A benchmark run away from the repository root says where the scenes
/// are looked for before it prints any table.
#[test]
fn benchmarks_without_their_examples_say_so_first() {
    let dir = tempfile::tempdir().expect("temp dir");
    for bench in ["derive", "gpu"] {
        let out = Command::new(env!("CARGO_BIN_EXE_grmc"))
            .args(["bench", bench, "--runs", "2"])
            .current_dir(dir.path())
            .output()
            .expect("grmc runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bench}: {err}");
        assert!(err.contains("--examples DIR"), "{bench}: {err}");
        assert!(
            out.stdout.is_empty(),
            "{bench}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
    }
}

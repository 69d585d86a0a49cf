//! The guide's reference pages stay in step with the code.
//!
//! `docs/src/reference/cli.md` is generated: the real binary's `--help`, for the top level
//! and for every command its help lists. A flag added, renamed or reworded without the page
//! fails `the_cli_reference_is_the_binarys_help`; `RAGDOLL_BLESS=1` rewrites the page
//! instead. The scene and spec pages are written by hand, so their tests only check that
//! every key the code reads is on the page.

mod common;

use std::path::Path;

use common::repo;

const CLI_PAGE: &str = "docs/src/reference/cli.md";

/// What `ragdoll ARGS` prints on stdout; it must succeed.
fn help(args: &[&str]) -> String {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .args(args)
        .output()
        .expect("the ragdoll binary runs");
    assert!(
        o.status.success(),
        "ragdoll {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).expect("help is UTF-8")
}

/// The commands the top-level help lists under `Commands:`, in its order (clap's own
/// `help` left out: it prints what `--help` does).
fn commands(top: &str) -> Vec<String> {
    let list = top
        .split("Commands:\n")
        .nth(1)
        .expect("the top-level help lists its commands");
    list.lines()
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_owned)
        .collect()
}

/// One section of the page: a heading and the help as a text block, trailing spaces cut.
fn section(heading: &str, text: &str) -> String {
    let body: Vec<&str> = text.trim_end().lines().map(str::trim_end).collect();
    format!("## `{heading}`\n\n```text\n{}\n```\n", body.join("\n"))
}

/// The page as the binary's help makes it now.
fn cli_page() -> String {
    let top = help(&["--help"]);
    let commands = commands(&top);
    assert!(commands.len() >= 10, "too few commands found: {commands:?}");
    let mut page = String::from(
        "# Command line\n\n\
         <!-- Generated from the binary's --help by crates/ragdoll-cli/tests/docs_reference.rs; \
         do not edit. After changing a command or a flag, run\n     \
         RAGDOLL_BLESS=1 cargo test --release -p ragdoll-cli --test docs_reference -->\n\n\
         This page is the `--help` of `ragdoll` and of each of its commands, as the binary \
         prints them; a test fails when it is out of date. The guide's other pages say what \
         the flags do in context: [Your own character](../your-character.md), [Blasts and \
         shots](../blasts.md), [Scenes](../scenes.md), [Backends](../backends.md), [Wedges \
         and farm jobs](../wedges.md), [The viewer](../viewer.md).\n\n",
    );
    page.push_str("## Commands\n\n");
    for name in &commands {
        page.push_str(&format!("- [`ragdoll {name}`](#ragdoll-{name})\n"));
    }
    page.push('\n');
    page.push_str(&section("ragdoll", &top));
    for name in &commands {
        page.push('\n');
        page.push_str(&section(
            &format!("ragdoll {name}"),
            &help(&[name, "--help"]),
        ));
    }
    page
}

/// The CLI reference is the binary's help, or is rewritten to it with `RAGDOLL_BLESS=1`.
#[test]
fn the_cli_reference_is_the_binarys_help() {
    let path = repo().join(CLI_PAGE);
    let made = cli_page();
    if std::env::var_os("RAGDOLL_BLESS").is_some_and(|v| v == "1") {
        std::fs::write(&path, &made).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != made {
        let line = committed
            .lines()
            .zip(made.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(committed.lines().count().min(made.lines().count()));
        panic!(
            "{CLI_PAGE} is not the binary's --help (first difference at line {}).\n\
             Run `RAGDOLL_BLESS=1 cargo test --release -p ragdoll-cli --test docs_reference` \
             to rewrite it, and commit the result.",
            line + 1
        );
    }
}

/// The keys serde reads in a source file: the fields of every item that derives
/// `Deserialize`, by their `rename` where they have one, less those serde skips.
fn serde_keys(source: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(source).unwrap();
    let (mut keys, mut armed, mut inside) = (Vec::new(), false, false);
    let (mut rename, mut skip) = (None, false);
    for line in text.lines() {
        if line.starts_with("#[derive(") {
            armed = line.contains("Deserialize");
            continue;
        }
        if armed && (line.starts_with("pub") || line.starts_with("struct")) {
            (inside, armed) = (line.contains("struct ") || line.contains("enum "), false);
            continue;
        }
        if line.starts_with('}') {
            inside = false;
        }
        let trimmed = line.trim_start();
        if !inside || trimmed.starts_with("//") {
            continue;
        }
        if trimmed.starts_with("#[serde(") {
            skip |= trimmed.contains("skip,") || trimmed.contains("skip)");
            if let Some(r) = trimmed.split("rename = \"").nth(1) {
                rename = r.split('"').next().map(str::to_owned);
            }
            continue;
        }
        let field = trimmed
            .trim_start_matches("pub(super) ")
            .trim_start_matches("pub ");
        let Some((name, _)) = field.split_once(": ") else {
            continue;
        };
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_lowercase() || c == '_') {
            continue;
        }
        if !skip {
            keys.push(rename.take().unwrap_or_else(|| name.to_owned()));
        }
        (rename, skip) = (None, false);
    }
    keys.sort();
    keys.dedup();
    keys
}

/// The keys of `source` that `page` does not name as a word.
fn missing(source: &str, page: &str) -> Vec<String> {
    let keys = serde_keys(&repo().join(source));
    assert!(
        keys.len() >= 10,
        "too few keys read from {source}: {keys:?}"
    );
    let text = std::fs::read_to_string(repo().join(page)).unwrap();
    let word = |c: char| c.is_ascii_alphanumeric() || c == '_';
    keys.into_iter()
        .filter(|k| {
            !text.match_indices(k.as_str()).any(|(i, _)| {
                let before = text[..i].chars().next_back().is_none_or(|c| !word(c));
                let after = text[i + k.len()..].chars().next().is_none_or(|c| !word(c));
                before && after
            })
        })
        .collect()
}

/// Every key a scene file may hold is on the scene file reference page.
#[test]
fn every_scene_key_is_in_the_reference() {
    let gone = missing(
        "crates/ragdoll/src/scene/raw.rs",
        "docs/src/reference/scene.md",
    );
    assert!(
        gone.is_empty(),
        "docs/src/reference/scene.md lacks {gone:?}"
    );
}

/// Every key a spec file may hold is on the spec reference page.
#[test]
fn every_spec_key_is_in_the_reference() {
    let gone = missing(
        "crates/ragdoll/src/spec/mod.rs",
        "docs/src/reference/spec.md",
    );
    assert!(gone.is_empty(), "docs/src/reference/spec.md lacks {gone:?}");
}

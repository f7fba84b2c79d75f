//! Dependencies between the firmware's modules run one way: no module imports from a module
//! that (directly or through others) imports from it.
//!
//! The sources are read as text: every `use` tree and every path in code that starts with
//! `crate`, `super`, `self` or the name of a child module is resolved to the module it names
//! (the longest prefix that is a module). Each file is one node; inline modules (`mod tests
//! { .. }`) belong to their file. The library (`src/lib.rs`), the application
//! (`src/main.rs`, with `src/platform/hw/` as its `hw`) and the bootloader
//! (`src/platform/bootloader/`) are separate crates; paths into other crates are not followed.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A module: which crate (lib or bin) and its path from that crate's root.
type ModPath = (Crate, Vec<String>);

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Crate {
    Lib,
    Bin,
    Boot,
}

/// One source file: its module, and where it is.
struct SourceFile {
    module: ModPath,
    path: PathBuf,
    text: String,
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("readable source directory") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            collect(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module a file defines: `a/b.rs` and `a/b/mod.rs` are `a::b`.
fn module_of(src: &Path, file: &Path) -> ModPath {
    let rel = file.strip_prefix(src).expect("file below src");
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().expect("a file name");
    let stem = last.trim_end_matches(".rs").to_string();
    if !matches!(stem.as_str(), "mod" | "lib" | "main") {
        parts.push(stem.clone());
    }
    // The binaries: the application (`main.rs`) with the hardware layer `platform/hw` as its
    // `hw`, and the bootloader (`platform/bootloader`, which includes the same `hw`).
    match parts.as_slice() {
        [p, hw, ..] if p == "platform" && hw == "hw" => (Crate::Bin, parts[1..].to_vec()),
        [p, b, ..] if p == "platform" && b == "bootloader" => (Crate::Boot, parts[2..].to_vec()),
        _ if stem == "main" => (Crate::Bin, parts),
        _ => (Crate::Lib, parts),
    }
}

/// The text with comments, string and character literals blanked (newlines kept, so byte
/// offsets still give line numbers).
fn code_only(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    let blank = |out: &mut Vec<u8>, c: u8| out.push(if c == b'\n' { b'\n' } else { b' ' });
    while i < b.len() {
        let rest = &b[i..];
        if rest.starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                blank(&mut out, b[i]);
                i += 1;
            }
        } else if rest.starts_with(b"/*") {
            let mut depth = 0;
            while i < b.len() {
                if b[i..].starts_with(b"/*") {
                    depth += 1;
                    out.extend_from_slice(b"  ");
                    i += 2;
                } else if b[i..].starts_with(b"*/") {
                    depth -= 1;
                    out.extend_from_slice(b"  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, b[i]);
                    i += 1;
                }
            }
        } else if rest.starts_with(b"r#\"") || rest.starts_with(b"r\"") {
            let hashes = rest[1..].iter().take_while(|c| **c == b'#').count();
            let close: Vec<u8> = std::iter::once(b'"')
                .chain(std::iter::repeat_n(b'#', hashes))
                .collect();
            let start = i + 2 + hashes;
            let end = b[start..]
                .windows(close.len())
                .position(|w| w == close.as_slice())
                .map_or(b.len(), |p| start + p + close.len());
            for &c in &b[i..end] {
                blank(&mut out, c);
            }
            i = end;
        } else if b[i] == b'"' {
            blank(&mut out, b[i]);
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' && i + 1 < b.len() {
                    blank(&mut out, b[i]);
                    i += 1;
                }
                blank(&mut out, b[i]);
                i += 1;
            }
            if i < b.len() {
                blank(&mut out, b[i]);
                i += 1;
            }
        } else if b[i] == b'\'' {
            // A character literal ('x', '\n', '\''), else a lifetime or label.
            let len = if rest.get(1) == Some(&b'\\') {
                rest.iter().skip(2).position(|c| *c == b'\'').map(|p| p + 3)
            } else {
                let ch = std::str::from_utf8(&rest[1..])
                    .ok()
                    .and_then(|s| s.chars().next())
                    .map_or(1, char::len_utf8);
                (rest.get(1 + ch) == Some(&b'\'')).then_some(ch + 2)
            };
            match len {
                Some(n) => {
                    for &c in &b[i..i + n] {
                        blank(&mut out, c);
                    }
                    i += n;
                }
                None => {
                    out.push(b[i]);
                    i += 1;
                }
            }
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).expect("blanking keeps UTF-8")
}

/// `code` (from [`code_only`]) with its test code blanked: the item after each
/// `#[cfg(test)]` (an inline `mod tests { .. }`, a `mod tests;`, a function). Tests may take
/// their fixtures from any module; the rules here are about the firmware's own code.
fn without_test_code(code: &str) -> String {
    const MARK: &str = "#[cfg(test)]";
    let mut out: Vec<u8> = code.as_bytes().to_vec();
    let mut from = 0;
    while let Some(at) = code[from..].find(MARK).map(|p| from + p) {
        let b = code.as_bytes();
        let mut i = at;
        let mut depth = 0usize;
        while i < b.len() {
            match b[i] {
                b'{' => depth += 1,
                b'}' => {
                    depth -= 1;
                    if depth == 0 {
                        i += 1;
                        break;
                    }
                }
                b';' if depth == 0 => {
                    i += 1;
                    break;
                }
                _ => {}
            }
            i += 1;
        }
        for c in &mut out[at..i] {
            if *c != b'\n' {
                *c = b' ';
            }
        }
        from = i;
    }
    String::from_utf8(out).expect("blanking keeps UTF-8")
}

/// True for a file that only tests compile (`tests.rs`, declared `#[cfg(test)] mod tests;`).
fn test_file(path: &Path) -> bool {
    path.file_name().is_some_and(|n| n == "tests.rs")
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Ident(String),
    PathSep,
    Punct(char),
}

/// Identifiers, `::` and single punctuation characters, with their line numbers.
fn tokens(code: &str) -> Vec<(Token, usize)> {
    let mut out = Vec::new();
    let mut line = 1;
    let chars: Vec<char> = code.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == '\n' {
            line += 1;
            i += 1;
        } else if c.is_whitespace() {
            i += 1;
        } else if c.is_alphanumeric() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push((Token::Ident(chars[start..i].iter().collect()), line));
        } else if c == ':' && chars.get(i + 1) == Some(&':') {
            out.push((Token::PathSep, line));
            i += 2;
        } else {
            out.push((Token::Punct(c), line));
            i += 1;
        }
    }
    out
}

/// The paths of a `use` tree starting at `tokens[i]` (after `use`), up to its `;`.
fn use_paths(
    tokens: &[(Token, usize)],
    i: &mut usize,
    prefix: &[String],
    out: &mut Vec<Vec<String>>,
) {
    let mut path = prefix.to_vec();
    while let Some((t, _)) = tokens.get(*i) {
        match t {
            Token::Ident(id) if id == "as" => {
                // `as name`: the path is complete.
                *i += 2;
                out.push(path.clone());
                return;
            }
            Token::Ident(id) => {
                path.push(id.clone());
                *i += 1;
            }
            Token::PathSep => *i += 1,
            Token::Punct('*') => {
                *i += 1;
                out.push(path.clone());
                return;
            }
            Token::Punct('{') => {
                *i += 1;
                loop {
                    use_paths(tokens, i, &path, out);
                    match tokens.get(*i) {
                        Some((Token::Punct(','), _)) => *i += 1,
                        Some((Token::Punct('}'), _)) => {
                            *i += 1;
                            break;
                        }
                        _ => break,
                    }
                    if matches!(tokens.get(*i), Some((Token::Punct('}'), _))) {
                        *i += 1;
                        break;
                    }
                }
                return;
            }
            _ => {
                if path.len() > prefix.len() {
                    out.push(path.clone());
                }
                return;
            }
        }
    }
}

/// Every path (with its line) that a file names: `use` trees and paths in code.
fn paths_of(code: &str) -> Vec<(Vec<String>, usize, Vec<String>)> {
    let toks = tokens(code);
    // Inline module nesting: (name, brace depth it opened at).
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut depth = 0usize;
    let mut out = Vec::new();
    let mut i = 0;
    while i < toks.len() {
        let here: Vec<String> = inline.iter().map(|(n, _)| n.clone()).collect();
        match &toks[i].0 {
            Token::Punct('{') => {
                depth += 1;
                i += 1;
            }
            Token::Punct('}') => {
                if inline.last().is_some_and(|(_, d)| *d == depth) {
                    inline.pop();
                }
                depth = depth.saturating_sub(1);
                i += 1;
            }
            Token::Ident(kw) if kw == "mod" => {
                if let (Some((Token::Ident(name), _)), Some((Token::Punct('{'), _))) =
                    (toks.get(i + 1), toks.get(i + 2))
                {
                    inline.push((name.clone(), depth + 1));
                }
                i += 1;
            }
            Token::Ident(kw) if kw == "use" => {
                let line = toks[i].1;
                i += 1;
                let mut paths = Vec::new();
                use_paths(&toks, &mut i, &[], &mut paths);
                out.extend(paths.into_iter().map(|p| (p, line, here.clone())));
            }
            Token::Ident(first) => {
                let after_sep = i > 0 && toks[i - 1].0 == Token::PathSep;
                if after_sep || toks.get(i + 1).map(|t| &t.0) != Some(&Token::PathSep) {
                    i += 1;
                    continue;
                }
                let line = toks[i].1;
                let mut path = vec![first.clone()];
                let mut j = i + 1;
                while let (Some((Token::PathSep, _)), Some((Token::Ident(id), _))) =
                    (toks.get(j), toks.get(j + 1))
                {
                    path.push(id.clone());
                    j += 2;
                }
                out.push((path, line, here));
                i = j;
            }
            _ => i += 1,
        }
    }
    out
}

/// The module a path names from module `from` (with `inline` modules open inside its file),
/// or `None` for paths into other crates and local items.
fn resolve(
    modules: &BTreeSet<ModPath>,
    from: &ModPath,
    inline: &[String],
    path: &[String],
) -> Option<ModPath> {
    let (krate, file_path) = from;
    let mut current: Vec<String> = file_path.iter().chain(inline).cloned().collect();
    let mut rest = path;
    let mut anchored = false;
    while let Some(first) = rest.first() {
        match first.as_str() {
            "crate" => current.clear(),
            "super" => {
                current.pop()?;
            }
            "self" => {}
            _ => break,
        }
        anchored = true;
        rest = &rest[1..];
    }
    let is_module = |p: &[String]| modules.contains(&(*krate, p.to_vec()));
    if !anchored {
        // A relative path: only a child module of `current` counts.
        let first = rest.first()?;
        let mut child = current.clone();
        child.push(first.clone());
        if !is_module(&child) {
            return None;
        }
    }
    let mut named = current;
    for seg in rest {
        let mut next = named.clone();
        next.push(seg.clone());
        if !is_module(&next) {
            break;
        }
        named = next;
    }
    Some((*krate, named))
}

/// The file node a module belongs to (inline modules belong to their file).
fn file_node(files: &BTreeSet<ModPath>, m: &ModPath) -> ModPath {
    let mut p = m.1.clone();
    loop {
        if files.contains(&(m.0, p.clone())) {
            return (m.0, p);
        }
        if p.pop().is_none() {
            return (m.0, Vec::new());
        }
    }
}

fn name(m: &ModPath) -> String {
    let root = match m.0 {
        Crate::Lib => "firmware",
        Crate::Bin => "application",
        Crate::Boot => "bootloader",
    };
    std::iter::once(root.to_string())
        .chain(m.1.iter().cloned())
        .collect::<Vec<_>>()
        .join("::")
}

/// Strongly connected components of more than one node (Tarjan).
fn cycles(graph: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> Vec<Vec<ModPath>> {
    struct State<'a> {
        graph: &'a BTreeMap<ModPath, BTreeSet<ModPath>>,
        index: BTreeMap<ModPath, usize>,
        low: BTreeMap<ModPath, usize>,
        stack: Vec<ModPath>,
        on_stack: BTreeSet<ModPath>,
        out: Vec<Vec<ModPath>>,
    }
    fn visit(s: &mut State, v: &ModPath) {
        let n = s.index.len();
        s.index.insert(v.clone(), n);
        s.low.insert(v.clone(), n);
        s.stack.push(v.clone());
        s.on_stack.insert(v.clone());
        let next: Vec<ModPath> = s.graph.get(v).into_iter().flatten().cloned().collect();
        for w in next {
            if !s.index.contains_key(&w) {
                visit(s, &w);
                let l = s.low[&w].min(s.low[v]);
                s.low.insert(v.clone(), l);
            } else if s.on_stack.contains(&w) {
                let l = s.index[&w].min(s.low[v]);
                s.low.insert(v.clone(), l);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(&w);
                let done = &w == v;
                component.push(w);
                if done {
                    break;
                }
            }
            if component.len() > 1 {
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out
}

/// The import graph of the firmware's sources, each edge with one place that makes it.
fn import_graph(src: &Path) -> BTreeMap<ModPath, BTreeMap<ModPath, String>> {
    let mut paths = Vec::new();
    collect(src, &mut paths);
    let files: Vec<SourceFile> = paths
        .into_iter()
        .map(|path| SourceFile {
            module: module_of(src, &path),
            text: std::fs::read_to_string(&path).expect("readable source file"),
            path,
        })
        .collect();
    let mut file_nodes: BTreeSet<ModPath> = files.iter().map(|f| f.module.clone()).collect();
    // The bootloader includes the application's `hw` as its own `hw` (`#[path]`): the same
    // files are modules of both binaries. Their imports are read once, as the application's.
    let shared_hw: Vec<ModPath> = file_nodes
        .iter()
        .filter(|(krate, path)| *krate == Crate::Bin && path.first().is_some_and(|p| p == "hw"))
        .map(|(_, path)| (Crate::Boot, path.clone()))
        .collect();
    file_nodes.extend(shared_hw);
    // Modules: the files and the inline modules they open.
    let mut modules = file_nodes.clone();
    let parsed: Vec<_> = files
        .iter()
        .map(|f| {
            let code = match test_file(&f.path) {
                true => String::new(),
                false => without_test_code(&code_only(&f.text)),
            };
            (f, paths_of(&code))
        })
        .collect();
    for (f, paths) in &parsed {
        for (_, _, inline) in paths {
            for k in 1..=inline.len() {
                let mut m = f.module.1.clone();
                m.extend(inline[..k].iter().cloned());
                modules.insert((f.module.0, m));
            }
        }
    }
    let mut graph: BTreeMap<ModPath, BTreeMap<ModPath, String>> = BTreeMap::new();
    for (f, paths) in &parsed {
        let from = &f.module;
        let edges = graph.entry(from.clone()).or_default();
        for (path, line, inline) in paths {
            let Some(to) = resolve(&modules, from, inline, path) else {
                continue;
            };
            let to = file_node(&file_nodes, &to);
            if &to != from {
                edges.entry(to).or_insert_with(|| {
                    format!("{}:{line} `{}`", f.path.display(), path.join("::"))
                });
            }
        }
    }
    graph
}

#[test]
fn no_module_imports_from_a_module_that_imports_from_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let graph = import_graph(&src);
    let plain: BTreeMap<ModPath, BTreeSet<ModPath>> = graph
        .iter()
        .map(|(k, v)| (k.clone(), v.keys().cloned().collect()))
        .collect();
    let found = cycles(&plain);
    let mut report = String::new();
    for component in &found {
        let members: BTreeSet<&ModPath> = component.iter().collect();
        let _ = writeln!(
            report,
            "modules that import from each other: {}",
            component.iter().map(name).collect::<Vec<_>>().join(", ")
        );
        for m in component {
            for (to, place) in &graph[m] {
                if members.contains(to) {
                    let _ = writeln!(report, "  {} -> {}: {place}", name(m), name(to));
                }
            }
        }
    }
    assert!(found.is_empty(), "\n{report}");
}

/// The library's layers, bottom up (`src/lib.rs`): a module imports only from its own
/// layer and the ones below.
const LAYERS: [&str; 4] = ["platform", "stacks", "io", "products"];

/// Modules that import nothing from each other: the EtherCAT slave application holds no
/// CAN code and the CANopen node no EtherCAT code; a product composes them.
const APART: [(&str, &str); 2] = [
    ("stacks::ethercat", "stacks::canopen"),
    ("stacks::canopen", "stacks::ethercat"),
];

fn layer(m: &ModPath) -> Option<usize> {
    let first = m.1.first()?;
    LAYERS.iter().position(|l| l == first)
}

fn within(m: &ModPath, prefix: &str) -> bool {
    let parts: Vec<&str> = prefix.split("::").collect();
    m.0 == Crate::Lib && m.1.len() >= parts.len() && m.1.iter().zip(&parts).all(|(a, b)| a == b)
}

/// The imports that break the layering (or [`APART`]), one line each.
fn layering_faults(graph: &BTreeMap<ModPath, BTreeMap<ModPath, String>>) -> Vec<String> {
    let mut faults = Vec::new();
    for (from, edges) in graph {
        for (to, place) in edges {
            if from.0 != Crate::Lib || to.0 != Crate::Lib {
                continue;
            }
            if let (Some(a), Some(b)) = (layer(from), layer(to)) {
                if b > a {
                    faults.push(format!(
                        "{} ({}) imports from {} ({}): {place}",
                        name(from),
                        LAYERS[a],
                        name(to),
                        LAYERS[b]
                    ));
                }
            }
            for (a, b) in APART {
                if within(from, a) && within(to, b) {
                    faults.push(format!("{} imports from {}: {place}", name(from), name(to)));
                }
            }
        }
    }
    faults
}

#[test]
fn each_layer_imports_only_from_the_layers_below() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let faults = layering_faults(&import_graph(&src));
    assert!(faults.is_empty(), "\n{}", faults.join("\n"));
}

/// The layering check finds an import upwards and one between the stacks, and leaves test
/// code alone.
#[test]
fn the_layering_check_finds_what_it_must() {
    let dir = std::env::temp_dir().join(format!("module-layers-{}", std::process::id()));
    let src = dir.join("src");
    for d in ["platform", "stacks/ethercat", "stacks/canopen", "products"] {
        std::fs::create_dir_all(src.join(d)).unwrap();
    }
    let files = [
        (
            "lib.rs",
            "pub mod platform; pub mod stacks; pub mod products;",
        ),
        ("platform/mod.rs", "pub mod board; use crate::products::P;"),
        (
            "platform/board.rs",
            "#[cfg(test)]\nmod tests { use crate::products::P; }",
        ),
        ("stacks/mod.rs", "pub mod ethercat; pub mod canopen;"),
        (
            "stacks/ethercat/mod.rs",
            "use crate::stacks::canopen::Node;",
        ),
        ("stacks/canopen/mod.rs", "use crate::platform::board::B;"),
        ("stacks/canopen/tests.rs", "use crate::products::P;"),
        (
            "products/mod.rs",
            "use crate::stacks::ethercat::S; pub struct P;",
        ),
    ];
    for (path, text) in files {
        std::fs::write(src.join(path), text).unwrap();
    }
    let mut faults = layering_faults(&import_graph(&src));
    std::fs::remove_dir_all(&dir).unwrap();
    faults.sort();
    let found: Vec<&str> = faults
        .iter()
        .map(|f| f.split(": /").next().unwrap_or(""))
        .collect();
    assert_eq!(
        found,
        [
            "firmware::platform (platform) imports from firmware::products (products)",
            "firmware::stacks::ethercat imports from firmware::stacks::canopen",
        ],
        "{faults:#?}"
    );
}

/// The checker finds what it must: a pair, a longer circle, `super`, relative paths and
/// `use` trees, and nothing in comments or strings.
#[test]
fn the_checker_finds_circles_and_ignores_comments() {
    let dir = std::env::temp_dir().join(format!("module-graph-{}", std::process::id()));
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("a")).unwrap();
    let files = [
        ("lib.rs", "pub mod a; pub mod b; pub mod c; pub mod d;"),
        // a imports its child x with a relative `use` tree; x imports a back through super.
        ("a/mod.rs", "pub mod x; use x::{Thing, other::Y};"),
        ("a/x.rs", "use super::Parent; pub struct Thing;"),
        // b -> c -> d -> b, through a path in code, a `use` and a `crate::` tree.
        ("b.rs", "fn f() { crate::c::g(); }"),
        ("c.rs", "use crate::d;"),
        ("d.rs", "use crate::{b::B as Bee};"),
        // Not imports: comments, strings, a local `mod tests` using super (its own file).
    ];
    for (path, text) in files {
        std::fs::write(src.join(path), text).unwrap();
    }
    std::fs::write(
        src.join("clean.rs"),
        "// use crate::a;\n/* crate::b::x */\nconst S: &str = \"crate::c\";\nmod tests { use super::*; }\n",
    )
    .unwrap();
    let graph = import_graph(&src);
    let plain: BTreeMap<ModPath, BTreeSet<ModPath>> = graph
        .iter()
        .map(|(k, v)| (k.clone(), v.keys().cloned().collect()))
        .collect();
    let mut found: Vec<Vec<String>> = cycles(&plain)
        .iter()
        .map(|c| {
            let mut names: Vec<String> = c.iter().map(name).collect();
            names.sort();
            names
        })
        .collect();
    found.sort();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(
        found,
        [
            vec!["firmware::a", "firmware::a::x"],
            vec!["firmware::b", "firmware::c", "firmware::d"],
        ]
    );
    let clean = plain
        .get(&(Crate::Lib, vec!["clean".to_string()]))
        .cloned()
        .unwrap_or_default();
    assert!(clean.is_empty(), "{clean:?}");
}

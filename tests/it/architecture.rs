//! The architecture's invariants as tests (rust-analyzer's `tidy` tests are
//! the model): the layers' one-way order, no import circles between files or
//! between top-level modules, files of at most 800 lines, a `//!` doc on
//! every source file, a core that does no I/O, protocol and mission crates
//! without the runtime, and a thin binary.
//!
//! The check reads the sources as text: every `crate::…`, `super::…` and
//! `self::…` path (in `use` trees, expressions and doc links) and every path
//! through a child module a file declares is resolved in the module tree
//! to the file that defines the item, following `pub use` re-exports, so
//! `crate::mission::MissionError` is an edge to `crates/mission/src/error.rs`. A
//! re-export itself is the module's public face, not a dependency of its
//! code, and makes no edge. `cargo test --test it architecture -- --nocapture`
//! prints the modules' dependency graph.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, bottom up: a module may refer to its own layer's modules and
/// to lower layers, never to a higher one (README, "Architecture").
const LAYERS: &[(&str, &[&str])] = &[
    ("core", &["geometry", "coverage", "control", "learning"]),
    ("protocol", &["protocol"]),
    ("mission", &["mission"]),
    ("recorder", &["recorder", "chain"]),
    ("shell", &["sim", "agent", "server", "load", "raster"]),
    ("demo", &["demo"]),
];

/// What the core may depend on: numerics and geometry only.
const CORE_DEPENDENCIES: &[&str] = &[
    "geo",
    "libm",
    "nalgebra",
    "rand",
    "rand_chacha",
    "rayon",
    "rstar",
    "smallvec",
    "thiserror",
];

/// What the wire types may depend on: serde, the schema derives, GeoJSON.
const PROTOCOL_DEPENDENCIES: &[&str] = &[
    "geojson",
    "schemars",
    "seacover-engine",
    "serde",
    "serde_json",
    "utoipa",
];

/// What the mission model may depend on: the layers below, geometry,
/// GeoJSON and its own errors.
const MISSION_DEPENDENCIES: &[&str] = &[
    "geo",
    "geojson",
    "seacover-engine",
    "seacover-protocol",
    "serde_json",
    "thiserror",
];

const MAX_LINES: usize = 800;
const MAX_MAIN_LINES: usize = 250;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// One source file: its module path (`["server", "coordinator", "tick"]`)
/// and its text.
struct File {
    path: PathBuf,
    module: Vec<String>,
    text: String,
}

/// The library's modules: `src/` with the lower layers' crates mounted where
/// `src/lib.rs` re-exports them: the engine's `crates/engine/src/` at the
/// root, `crates/protocol/src/` at `protocol` and `crates/mission/src/` at
/// `mission`. A mounted crate's paths are read as the library's: its
/// `crate::` as its mount point, a lower crate's name as that crate's.
fn library() -> Vec<File> {
    let mut files = Vec::new();
    collect(&root().join("src"), &[], &mut files, true);
    collect(&root().join("crates/engine/src"), &[], &mut files, true);
    for (krate, mount) in [("protocol", "protocol"), ("mission", "mission")] {
        let mut mounted = Vec::new();
        collect(
            &root().join(format!("crates/{krate}/src")),
            &[mount.to_string()],
            &mut mounted,
            true,
        );
        for f in &mut mounted {
            f.text = as_mounted(&f.text, mount);
        }
        files.extend(mounted);
    }
    files
}

/// A mounted crate's text with its paths as the library's. In this order:
/// the crate's own `crate::` moves to its mount point before a lower crate's
/// name becomes `crate::`. (Neither crate has `$crate` or an identifier
/// ending in these names.)
fn as_mounted(text: &str, mount: &str) -> String {
    text.replace("crate::", &format!("crate::{mount}::"))
        .replace("seacover_engine::", "crate::")
        .replace("seacover_protocol::", "crate::protocol::")
}

/// The binary's modules, as a crate of their own.
fn binary() -> Vec<File> {
    let mut files = Vec::new();
    collect(&root().join("src/bin/seacover"), &[], &mut files, false);
    files
}

fn collect(dir: &Path, module: &[String], out: &mut Vec<File>, skip_bin: bool) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for path in entries {
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        if path.is_dir() {
            if skip_bin && module.is_empty() && name == "bin" {
                continue;
            }
            let mut m = module.to_vec();
            m.push(name);
            collect(&path, &m, out, skip_bin);
        } else if let Some(stem) = name.strip_suffix(".rs") {
            let mut m = module.to_vec();
            if !matches!(stem, "mod" | "lib" | "main") {
                m.push(stem.to_string());
            }
            out.push(File {
                text: std::fs::read_to_string(&path).unwrap(),
                path,
                module: m,
            });
        }
    }
}

/// The text without comments other than doc comments' link targets: line
/// comments are dropped, except that `](crate::…)` and `[`crate::…`]` links
/// in doc comments are kept.
fn code_and_doc_links(text: &str) -> String {
    let mut out = String::new();
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("//!") || trimmed.starts_with("///") {
            // Keep only link targets.
            for (i, _) in trimmed.match_indices("crate::") {
                let rest = &trimmed[i..];
                let end = rest
                    .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                    .unwrap_or(rest.len());
                out.push_str(&rest[..end]);
                out.push(';');
            }
            out.push('\n');
        } else if trimmed.starts_with("//") {
            out.push('\n');
        } else {
            let code = match line.find(" // ") {
                Some(i) if !line[..i].contains('"') => &line[..i],
                _ => line,
            };
            out.push_str(code);
            out.push('\n');
        }
    }
    out
}

/// Expands a `use` tree (`a::{b, c::{d, e}}`) into its paths.
fn expand(tree: &str) -> Vec<String> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        let path = tree.split(" as ").next().unwrap().trim();
        return if path.is_empty() {
            vec![]
        } else {
            vec![path.to_string()]
        };
    };
    let prefix = tree[..open].trim();
    let inner = &tree[open + 1..tree.rfind('}').expect("balanced braces")];
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .into_iter()
        .flat_map(expand)
        .map(|p| {
            if p == "self" {
                prefix.trim_end_matches("::").to_string()
            } else {
                format!("{prefix}{p}")
            }
        })
        .collect()
}

/// The text with every inline module's (`mod tests { … }`) `super::` read
/// as `self::`: inside it, `super` is the file's own module.
fn flatten_inline_modules(code: &str) -> String {
    let mut out = code.to_string();
    let mut from = 0;
    while let Some(i) = out[from..].find("mod ") {
        let at = from + i;
        from = at + 4;
        let rest = &out[at + 4..];
        let name_end = rest
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(rest.len());
        if name_end == 0 || !rest[name_end..].trim_start().starts_with('{') {
            continue;
        }
        let open = at + 4 + name_end + rest[name_end..].find('{').unwrap();
        let mut depth = 0;
        let mut close = out.len();
        for (k, c) in out[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        close = open + k;
                        break;
                    }
                }
                _ => {}
            }
        }
        let inner = out[open..close]
            .replace("super::", "self::")
            .replace("use super", "use self");
        out.replace_range(open..close, &inner);
    }
    out
}

/// The child modules a file declares (`mod x;`).
fn children(code: &str) -> Vec<String> {
    code.lines()
        .filter_map(|l| {
            let l = l.trim();
            let l = l.strip_prefix("pub ").unwrap_or(l);
            let name = l.strip_prefix("mod ")?.strip_suffix(';')?;
            Some(name.trim().to_string())
        })
        .collect()
}

/// A file's references: (path, whether it is a `pub use` re-export).
fn references(text: &str) -> Vec<(String, bool)> {
    let code = flatten_inline_modules(&code_and_doc_links(text));
    let mut out = Vec::new();
    let mut rest = code.as_str();
    let mut outside_use = String::new();
    // `use` statements, then every other path.
    while let Some(i) = find_use(rest) {
        outside_use.push_str(&rest[..i]);
        let stmt_start = i;
        let end = rest[i..].find(';').map(|e| i + e).unwrap_or(rest.len());
        let stmt = &rest[stmt_start..end];
        let public = stmt.starts_with("pub");
        let tree = stmt[stmt.find("use ").unwrap() + 4..].to_string();
        out.extend(expand(&tree).into_iter().map(|p| (p, public)));
        rest = &rest[end.min(rest.len())..];
    }
    outside_use.push_str(rest);
    let bytes = outside_use.as_bytes();
    let keys: Vec<String> = ["crate", "super", "self"]
        .into_iter()
        .map(String::from)
        .chain(children(&code))
        .map(|k| format!("{k}::"))
        .collect();
    for key in &keys {
        for (i, _) in outside_use.match_indices(key.as_str()) {
            if i > 0
                && (bytes[i - 1].is_ascii_alphanumeric()
                    || bytes[i - 1] == b'_'
                    || bytes[i - 1] == b':')
            {
                continue;
            }
            let tail = &outside_use[i..];
            let end = tail
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(tail.len());
            out.push((tail[..end].trim_end_matches(':').to_string(), false));
        }
    }
    out
}

/// Where the next `use` statement starts (at `use` or its `pub`).
fn find_use(text: &str) -> Option<usize> {
    let mut from = 0;
    while let Some(i) = text[from..].find("use ") {
        let at = from + i;
        let line_start = text[..at].rfind('\n').map_or(0, |n| n + 1);
        let before = text[line_start..at].trim();
        if before.is_empty() || before == "pub" || before.starts_with("pub(") {
            return Some(if before.is_empty() {
                at
            } else {
                line_start + text[line_start..].find(before).unwrap()
            });
        }
        from = at + 4;
    }
    None
}

/// The module tree: each module's file, child modules and re-exports.
struct Tree {
    files: BTreeMap<Vec<String>, usize>,
    /// (module, name) → the absolute path it re-exports.
    reexports: BTreeMap<(Vec<String>, String), Vec<String>>,
}

impl Tree {
    fn new(files: &[File]) -> Tree {
        let mut tree = Tree {
            files: files
                .iter()
                .enumerate()
                .map(|(i, f)| (f.module.clone(), i))
                .collect(),
            reexports: BTreeMap::new(),
        };
        for f in files {
            for (path, public) in references(&f.text) {
                if !public {
                    continue;
                }
                if let Some(abs) = tree.absolute(f, &path) {
                    let name = abs.last().unwrap().clone();
                    tree.reexports.insert((f.module.clone(), name), abs);
                }
            }
        }
        tree
    }

    /// A path as absolute segments from the crate root, or `None` for a
    /// path outside the crate (std, dependencies, locals).
    fn absolute(&self, file: &File, path: &str) -> Option<Vec<String>> {
        let segs: Vec<&str> = path.split("::").filter(|s| !s.is_empty()).collect();
        let (mut base, mut rest): (Vec<String>, &[&str]) = (file.module.clone(), &segs[..]);
        match segs.first()? {
            &"crate" => {
                base.clear();
                rest = &segs[1..];
            }
            &"self" => rest = &segs[1..],
            &"super" => {
                while let Some(&"super") = rest.first() {
                    base.pop()?;
                    rest = &rest[1..];
                }
            }
            first => {
                let mut child = base.clone();
                child.push(first.to_string());
                if !self.files.contains_key(&child) {
                    return None;
                }
            }
        }
        base.extend(rest.iter().map(|s| s.to_string()));
        Some(base)
    }

    /// The file that defines what `abs` names.
    fn resolve(&self, abs: &[String], depth: usize) -> Option<usize> {
        let mut module: Vec<String> = Vec::new();
        for (i, seg) in abs.iter().enumerate() {
            let mut child = module.clone();
            child.push(seg.clone());
            if self.files.contains_key(&child) {
                module = child;
                continue;
            }
            if depth < 8
                && let Some(target) = self.reexports.get(&(module.clone(), seg.clone()))
            {
                let mut next = target.clone();
                next.extend(abs[i + 1..].iter().cloned());
                return self.resolve(&next, depth + 1);
            }
            break;
        }
        self.files.get(&module).copied()
    }
}

/// File → files it depends on.
fn edges(files: &[File]) -> BTreeMap<usize, BTreeSet<usize>> {
    labelled_edges(files)
        .into_iter()
        .map(|(i, to)| (i, to.into_keys().collect()))
        .collect()
}

/// File → files it depends on, each with the first path that makes the
/// dependency (for the failure messages).
fn labelled_edges(files: &[File]) -> BTreeMap<usize, BTreeMap<usize, String>> {
    let tree = Tree::new(files);
    let mut out: BTreeMap<usize, BTreeMap<usize, String>> = BTreeMap::new();
    for (i, f) in files.iter().enumerate() {
        let set = out.entry(i).or_default();
        for (path, public) in references(&f.text) {
            if public {
                continue;
            }
            let path = path.trim_end_matches("::*");
            if let Some(abs) = tree.absolute(f, path)
                && let Some(j) = tree.resolve(&abs, 0)
                && j != i
            {
                set.entry(j).or_insert_with(|| path.to_string());
            }
        }
    }
    out
}

/// The cycles of a graph: its strongly connected components of more than
/// one node (Tarjan).
fn cycles<N: Ord + Clone>(graph: &BTreeMap<N, BTreeSet<N>>) -> Vec<Vec<N>> {
    struct State<N> {
        index: BTreeMap<N, usize>,
        low: BTreeMap<N, usize>,
        stack: Vec<N>,
        on: BTreeSet<N>,
        out: Vec<Vec<N>>,
    }
    fn visit<N: Ord + Clone>(n: &N, g: &BTreeMap<N, BTreeSet<N>>, s: &mut State<N>) {
        let i = s.index.len();
        s.index.insert(n.clone(), i);
        s.low.insert(n.clone(), i);
        s.stack.push(n.clone());
        s.on.insert(n.clone());
        for m in g.get(n).into_iter().flatten() {
            if !s.index.contains_key(m) {
                visit(m, g, s);
                let l = s.low[m].min(s.low[n]);
                s.low.insert(n.clone(), l);
            } else if s.on.contains(m) {
                let l = s.index[m].min(s.low[n]);
                s.low.insert(n.clone(), l);
            }
        }
        if s.low[n] == s.index[n] {
            let mut scc = Vec::new();
            loop {
                let m = s.stack.pop().unwrap();
                s.on.remove(&m);
                scc.push(m.clone());
                if &m == n {
                    break;
                }
            }
            if scc.len() > 1 {
                s.out.push(scc);
            }
        }
    }
    let mut s = State {
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for n in graph.keys() {
        if !s.index.contains_key(n) {
            visit(n, graph, &mut s);
        }
    }
    s.out
}

fn layer_of(top: &str) -> Option<usize> {
    LAYERS
        .iter()
        .position(|(_, modules)| modules.contains(&top))
}

fn display(files: &[File], i: usize) -> String {
    files[i]
        .path
        .strip_prefix(root())
        .unwrap()
        .display()
        .to_string()
}

#[test]
fn layers_point_one_way_down() {
    let files = library();
    let graph = edges(&files);
    let mut problems = Vec::new();
    let mut modules: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (&i, targets) in &graph {
        let Some(top) = files[i].module.first() else {
            continue; // lib.rs: the code map and re-exports
        };
        let Some(from) = layer_of(top) else {
            problems.push(format!(
                "{}: module `{top}` is in no layer (tests/it/architecture.rs LAYERS)",
                display(&files, i)
            ));
            continue;
        };
        for &j in targets {
            let Some(target) = files[j].module.first() else {
                continue;
            };
            modules.entry(top.clone()).or_default();
            if target != top {
                modules.get_mut(top).unwrap().insert(target.clone());
            }
            if layer_of(target).is_some_and(|to| to > from) {
                problems.push(format!(
                    "{} ({}) refers up to {} ({})",
                    display(&files, i),
                    LAYERS[from].0,
                    display(&files, j),
                    LAYERS[layer_of(target).unwrap()].0
                ));
            }
        }
    }
    println!("top-level modules and what they refer to:");
    for (m, to) in &modules {
        println!(
            "  {m} → {}",
            to.iter().cloned().collect::<Vec<_>>().join(", ")
        );
    }
    for cycle in cycles(&modules) {
        problems.push(format!("modules in a circle: {}", cycle.join(" → ")));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn no_file_imports_in_a_circle() {
    for files in [library(), binary()] {
        let labelled = labelled_edges(&files);
        let found: Vec<String> = cycles(&edges(&files))
            .into_iter()
            .map(|c| {
                let members: BTreeSet<usize> = c.iter().copied().collect();
                let mut text = c
                    .iter()
                    .map(|&i| display(&files, i))
                    .collect::<Vec<_>>()
                    .join(" ↔ ");
                for &i in &members {
                    for (j, path) in &labelled[&i] {
                        if members.contains(j) {
                            text.push_str(&format!(
                                "\n    {} → {} ({path})",
                                display(&files, i),
                                display(&files, *j)
                            ));
                        }
                    }
                }
                text
            })
            .collect();
        assert!(
            found.is_empty(),
            "files in an import circle:\n{}",
            found.join("\n")
        );
    }
}

#[test]
fn the_layers_are_the_modules() {
    // Every top-level module of the library is in a layer, and every layer's
    // module exists: the table cannot drift from the tree.
    let files = library();
    let tops: BTreeSet<&str> = files
        .iter()
        .filter_map(|f| f.module.first().map(String::as_str))
        .collect();
    let listed: BTreeSet<&str> = LAYERS.iter().flat_map(|(_, m)| m.iter().copied()).collect();
    assert_eq!(tops, listed);
}

#[test]
fn source_files_are_short_and_documented() {
    let mut problems = Vec::new();
    for f in library().into_iter().chain(binary()) {
        let lines = f.text.lines().count();
        let name = f.path.strip_prefix(root()).unwrap().display().to_string();
        if lines > MAX_LINES {
            problems.push(format!(
                "{name}: {lines} lines (at most {MAX_LINES}: split it along its seams)"
            ));
        }
        let first = f.text.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
        if !first.starts_with("//!") {
            problems.push(format!("{name}: no `//!` doc saying what it is for"));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_binary_is_thin() {
    let main = root().join("src/bin/seacover/main.rs");
    let lines = std::fs::read_to_string(&main).unwrap().lines().count();
    assert!(
        lines <= MAX_MAIN_LINES,
        "{}: {lines} lines (at most {MAX_MAIN_LINES})",
        main.display()
    );
    // One file per subcommand, and no library code outside the library: the
    // binary's files use `anyhow`, the library does not.
    for f in library() {
        assert!(
            !f.text.contains("anyhow"),
            "{}: anyhow belongs to the binary; the library has its own errors",
            f.path.display()
        );
    }
}

/// The `[dependencies]` of a crate of the workspace (`crates/<name>`).
fn dependencies(krate: &str) -> Vec<String> {
    let path = root().join(format!("crates/{krate}/Cargo.toml"));
    let manifest = std::fs::read_to_string(&path).unwrap();
    let mut section = "";
    let mut names = Vec::new();
    for line in manifest.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            section = line;
            continue;
        }
        if section == "[dependencies]"
            && let Some((name, _)) = line.split_once('=')
        {
            names.push(name.trim().to_string());
        }
    }
    names
}

#[test]
fn the_protocol_and_the_mission_have_no_runtime() {
    // The layers between the core and the shell: serde and schemas, then
    // documents ⇄ core types. No async, network or storage crate may come
    // in below the recorder (the fuzz targets build on these crates alone).
    for (krate, allowed) in [
        ("protocol", PROTOCOL_DEPENDENCIES),
        ("mission", MISSION_DEPENDENCIES),
    ] {
        for name in dependencies(krate) {
            assert!(
                allowed.contains(&name.as_str()),
                "crates/{krate} depends on {name}: the {krate} layer has no I/O and no runtime \
                 (tests/it/architecture.rs lists what it may use)"
            );
        }
    }
}

#[test]
fn the_core_does_no_io() {
    for name in dependencies("engine") {
        assert!(
            CORE_DEPENDENCIES.contains(&name.as_str()),
            "the core depends on {name}: only numerics and geometry may be below the protocol"
        );
    }
    let forbidden = [
        "std::fs",
        "std::net",
        "std::io",
        "std::env",
        "std::process",
        "std::thread::sleep",
        "Instant",
        "SystemTime",
        "tokio",
        "serde",
        "println!",
        "eprintln!",
    ];
    let files = library();
    for f in &files {
        let core = f.module.first().is_some_and(|m| layer_of(m) == Some(0));
        if !core {
            continue;
        }
        // Unit tests may print; the code they test may not. A module's
        // tests are the end of its file or, declared there as
        // `#[cfg(test)] mod tests;`, a file `tests.rs` of their own.
        let own_tests = f.module.last().is_some_and(|m| m == "tests")
            && files.iter().any(|parent| {
                parent.module[..] == f.module[..f.module.len() - 1]
                    && parent.text.contains("#[cfg(test)]\nmod tests;")
            });
        if own_tests {
            continue;
        }
        let text = f.text.split("#[cfg(test)]\nmod tests").next().unwrap();
        let code = code_and_doc_links(text);
        for word in forbidden {
            assert!(
                !code.contains(word),
                "{}: the core uses {word}",
                f.path.display()
            );
        }
    }
}

/// The checker itself: it must find what it is for.
#[test]
fn the_checker_finds_circles_and_resolves_reexports() {
    let file = |module: &[&str], text: &str| File {
        path: root().join(format!("{}.rs", module.join("/"))),
        module: module.iter().map(|s| s.to_string()).collect(),
        text: text.to_string(),
    };
    let files = vec![
        file(&[], "pub mod a;\npub mod b;"),
        file(
            &["a"],
            "//! a\nmod inner;\npub use inner::Thing;\nuse crate::b::{self, Other};",
        ),
        file(&["a", "inner"], "//! inner\npub struct Thing;"),
        file(
            &["b"],
            "//! b\npub struct Other;\nfn f() { let _ = crate::a::Thing; }",
        ),
    ];
    let graph = edges(&files);
    // a → b (a use tree); b → a::inner (through the re-export), not → a.
    assert_eq!(graph[&1], BTreeSet::from([3]));
    assert_eq!(graph[&3], BTreeSet::from([2]));
    assert!(cycles(&graph).is_empty());
    let mut circular = files;
    circular[2].text.push_str("\nuse crate::b::Other;");
    assert_eq!(cycles(&edges(&circular)).len(), 1);
    assert_eq!(
        expand("crate::{a::{b, c as d}, e}"),
        ["crate::a::b", "crate::a::c", "crate::e"]
    );
}

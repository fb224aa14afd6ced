//! Hygiene as tests (rust-analyzer's `xtask/src/tidy.rs` is the model):
//! what a reader of a fresh clone meets must hold together.
//!
//! - every tracked file's name is plain: letters, digits and `._-/` (an
//!   explicit allow-list for any other, empty today);
//! - every relative link in the Markdown pages resolves, to a file that
//!   exists and, with a `#fragment`, to a heading or anchor of that page;
//! - every repository path a `//`, `//!` or `///` comment names exists;
//! - no tracked text cites the first contract or an issue tracker's numbers
//!   (the repository's own docs/ and the paper are what code cites);
//! - no function of the library or the binary is longer than
//!   [`MAX_FN_LINES`] lines (tests are exempt).
//!
//! Each check is a function over text, so the tests at the end plant a
//! failing example in each and see it fail.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The longest function the library and the binary may hold.
const MAX_FN_LINES: usize = 120;

/// Tracked files whose names may hold more than `[A-Za-z0-9._/-]`.
const ODD_NAMES: &[&str] = &[];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The repository's files, relative to its root: git's index in a clone,
/// else (an unpacked archive) every file outside `target/` and `.git/`.
fn tracked() -> Vec<String> {
    let git = std::process::Command::new("git")
        .args(["ls-files", "-z"])
        .current_dir(root())
        .output();
    if let Ok(out) = git
        && out.status.success()
    {
        return String::from_utf8(out.stdout)
            .expect("UTF-8 paths")
            .split('\0')
            .filter(|p| !p.is_empty() && root().join(p).exists())
            .map(String::from)
            .collect();
    }
    let mut out = Vec::new();
    walk(&root(), "", &mut out);
    out
}

fn walk(dir: &Path, prefix: &str, out: &mut Vec<String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name().to_string_lossy().into_owned();
        if prefix.is_empty() && (name == "target" || name == ".git") {
            continue;
        }
        let rel = format!("{prefix}{name}");
        if entry.file_type().unwrap().is_dir() {
            walk(&entry.path(), &format!("{rel}/"), out);
        } else {
            out.push(rel);
        }
    }
}

fn text_of(path: &str) -> Option<String> {
    std::fs::read_to_string(root().join(path)).ok()
}

// ---- file names ----

/// The names among `paths` with a character outside `[A-Za-z0-9._/-]`.
fn odd_names<'a>(paths: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    paths
        .into_iter()
        .filter(|p| {
            !p.chars()
                .all(|c| c.is_ascii_alphanumeric() || "._-/".contains(c))
        })
        .filter(|p| !ODD_NAMES.contains(p))
        .map(String::from)
        .collect()
}

// ---- Markdown links ----

/// A Markdown text without its fenced code blocks and inline code spans
/// (blanked, so that line numbers stay).
fn prose(md: &str) -> String {
    let mut out = String::new();
    let mut fenced = false;
    for line in md.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            out.push('\n');
            continue;
        }
        if fenced {
            out.push('\n');
            continue;
        }
        let mut in_code = false;
        for c in line.chars() {
            if c == '`' {
                in_code = !in_code;
            }
            out.push(if in_code || c == '`' { ' ' } else { c });
        }
        out.push('\n');
    }
    out
}

/// GitHub's anchor for a heading: lower case, punctuation but `-` and `_`
/// dropped, spaces as `-`; a repeated one gets `-1`, `-2`, ….
fn anchors(md: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut fenced = false;
    for line in md.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        if fenced {
            continue;
        }
        if let Some(title) = line.strip_prefix('#') {
            let title = title.trim_start_matches('#').trim();
            // A link in a heading counts by its text only.
            let title = strip_links(title);
            let slug: String = title
                .to_lowercase()
                .chars()
                .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
                .map(|c| if c == ' ' { '-' } else { c })
                .collect();
            let mut anchor = slug.clone();
            let mut n = 0;
            while seen.contains(&anchor) {
                n += 1;
                anchor = format!("{slug}-{n}");
            }
            seen.insert(anchor);
        }
        for attr in ["id=\"", "name=\""] {
            let mut rest = line;
            while let Some(i) = rest.find(attr) {
                rest = &rest[i + attr.len()..];
                if let Some(end) = rest.find('"') {
                    seen.insert(rest[..end].to_string());
                }
            }
        }
    }
    seen
}

/// `[text](target)` as `text`.
fn strip_links(s: &str) -> String {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find("](") {
        let Some(close) = rest[i..].find(')') else {
            break;
        };
        out.push_str(&rest[..i].replacen('[', "", 1));
        rest = &rest[i + close + 1..];
    }
    out.push_str(rest);
    out
}

/// The link targets of a Markdown text with their line numbers: inline
/// links, reference definitions and `href`/`src` attributes. An inline link
/// whose target never closes on its line is reported as `Err`.
fn link_targets(md: &str) -> Vec<(usize, Result<String, String>)> {
    let mut out = Vec::new();
    for (n, line) in prose(md).lines().enumerate() {
        let n = n + 1;
        let mut rest = line;
        while let Some(i) = rest.find("](") {
            rest = &rest[i + 2..];
            let mut depth = 0usize;
            let end = rest.char_indices().find_map(|(j, c)| match c {
                '(' => {
                    depth += 1;
                    None
                }
                ')' if depth == 0 => Some(j),
                ')' => {
                    depth -= 1;
                    None
                }
                _ => None,
            });
            match end {
                Some(j) => {
                    let target = rest[..j].split_whitespace().next().unwrap_or("");
                    out.push((n, Ok(target.to_string())));
                    rest = &rest[j + 1..];
                }
                None => {
                    out.push((n, Err(format!("a link that never closes: ]({rest}"))));
                    break;
                }
            }
        }
        let t = line.trim_start();
        if t.starts_with('[')
            && let Some(i) = t.find("]: ")
        {
            let target = t[i + 3..].split_whitespace().next().unwrap_or("");
            out.push((n, Ok(target.to_string())));
        }
        for attr in ["href=\"", "src=\""] {
            let mut rest = line;
            while let Some(i) = rest.find(attr) {
                rest = &rest[i + attr.len()..];
                if let Some(end) = rest.find('"') {
                    out.push((n, Ok(rest[..end].to_string())));
                }
            }
        }
    }
    out
}

/// The broken relative links of the page `page` (a path under `base`),
/// given how to read another page: `(line, what is wrong)`.
fn broken_links(
    page: &str,
    md: &str,
    exists: &dyn Fn(&str) -> bool,
    read: &dyn Fn(&str) -> Option<String>,
) -> Vec<String> {
    let dir = Path::new(page).parent().unwrap_or(Path::new(""));
    let mut broken = Vec::new();
    for (n, target) in link_targets(md) {
        let target = match target {
            Ok(t) => t,
            Err(e) => {
                broken.push(format!("{page}:{n}: {e}"));
                continue;
            }
        };
        if target.is_empty() || target.contains("://") || target.starts_with("mailto:") {
            continue;
        }
        let (file, fragment) = match target.split_once('#') {
            Some((f, a)) => (f, Some(a)),
            None => (target.as_str(), None),
        };
        let resolved = if file.is_empty() {
            page.to_string()
        } else {
            match normalize(&dir.join(file)) {
                Some(p) => p,
                None => {
                    broken.push(format!("{page}:{n}: {target} leaves the repository"));
                    continue;
                }
            }
        };
        if !exists(&resolved) {
            broken.push(format!("{page}:{n}: {target}: no {resolved}"));
            continue;
        }
        if let Some(fragment) = fragment
            && resolved.ends_with(".md")
            && !read(&resolved).is_some_and(|t| anchors(&t).contains(fragment))
        {
            broken.push(format!("{page}:{n}: {target}: no heading #{fragment}"));
        }
    }
    broken
}

/// `a/b/../c/./d` as `a/c/d`, or `None` above the root.
fn normalize(path: &Path) -> Option<String> {
    let mut parts: Vec<String> = Vec::new();
    for c in path.components() {
        match c {
            std::path::Component::ParentDir => {
                parts.pop()?;
            }
            std::path::Component::Normal(s) => parts.push(s.to_string_lossy().into_owned()),
            _ => {}
        }
    }
    Some(parts.join("/"))
}

// ---- paths in comments ----

/// The comment texts of a Rust or JavaScript source (`//`, `//!`, `///`)
/// with their line numbers. A `//` inside a string literal on the same line
/// is read as a comment too: harmless here, since only repository paths in
/// it are checked, and URLs are not such paths.
fn comments(src: &str) -> Vec<(usize, &str)> {
    src.lines()
        .enumerate()
        .filter_map(|(n, l)| l.find("//").map(|i| (n + 1, &l[i + 2..])))
        .collect()
}

/// The repository paths a comment names that do not exist: a run of
/// `[A-Za-z0-9_./-]` whose first component is one of the repository's
/// top-level entries (`tops`). A path may also be relative to its crate
/// (`crate_root`). A run followed by `*`, `…`, `<` or `{` is a pattern:
/// some file must start with it.
fn dangling_paths(
    comment: &str,
    tops: &BTreeSet<String>,
    crate_root: &str,
    files: &BTreeSet<String>,
) -> Vec<String> {
    let is_path_char = |c: char| c.is_ascii_alphanumeric() || "_./-".contains(c);
    let mut out = Vec::new();
    let mut rest = comment;
    while let Some(start) = rest.find(is_path_char) {
        // A run must not continue a word or a URL (`https://x/src/…`).
        let before = rest[..start].chars().next_back();
        let tail = &rest[start..];
        let len = tail.find(|c| !is_path_char(c)).unwrap_or(tail.len());
        let run = &tail[..len];
        let next = tail[len..].chars().next();
        rest = &tail[len..];
        if before == Some(':') || before == Some('/') || !run.contains('/') {
            continue;
        }
        let run = run.trim_end_matches(['.', ',', ':', ';']);
        let first = run.split('/').next().unwrap_or("");
        if !tops.contains(first) && !tops.contains(&format!("{crate_root}/{first}")) {
            continue;
        }
        let pattern = matches!(next, Some('*' | '…' | '<' | '{'));
        let found = [run.to_string(), format!("{crate_root}/{run}")]
            .iter()
            .any(|p| {
                let p = p.trim_end_matches('/');
                if pattern {
                    files.iter().any(|f| f.starts_with(p))
                } else {
                    files.contains(p) || files.iter().any(|f| f.starts_with(&format!("{p}/")))
                }
            });
        if !found {
            out.push(run.to_string());
        }
    }
    out
}

/// Where a path in a comment of `file` may be relative to: its crate's
/// directory (`crates/engine` for `crates/engine/src/…`), else the root.
fn crate_root(file: &str) -> String {
    let parts: Vec<&str> = file.split('/').collect();
    if parts.len() > 2 && parts[0] == "crates" {
        format!("crates/{}", parts[1])
    } else if parts[0] == "fuzz" {
        "fuzz".into()
    } else {
        String::new()
    }
}

// ---- citations ----

/// Lines citing the first contract's sections or an issue's number.
fn citations(text: &str) -> Vec<usize> {
    let contract = concat!("SP", "EC §");
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let lower = line.to_lowercase();
        let issue = lower.match_indices(concat!("iss", "ue")).any(|(i, w)| {
            let after = lower[i + w.len()..].trim_start_matches([' ', '#']);
            lower[i + w.len()..].starts_with([' ', '#'])
                && after.starts_with(|c: char| c.is_ascii_digit())
        });
        if line.contains(contract) || issue {
            out.push(n + 1);
        }
    }
    out
}

// ---- function lengths ----

/// The functions of a Rust source with more than `max` lines, from `fn`
/// to its closing brace, as `(name, lines)`. Skips `#[cfg(test)]` modules.
/// Strings, characters and comments are read past, so a brace in them does
/// not count.
fn long_functions(src: &str, max: usize) -> Vec<(String, usize)> {
    let code = blank_literals(src);
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    let mut skip_until = 0;
    for (i, line) in lines.iter().enumerate() {
        if i < skip_until {
            continue;
        }
        let t = line.trim_start();
        if t.starts_with("#[cfg(test)]") {
            if let Some(end) = block_end(&lines, i) {
                skip_until = end + 1;
            }
            continue;
        }
        let Some(at) = find_fn(t) else { continue };
        let name: String = t[at + 3..]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if name.is_empty() {
            continue;
        }
        if let Some(end) = block_end(&lines, i) {
            let n = end - i + 1;
            if n > max {
                out.push((name, n));
            }
        }
    }
    out
}

/// Where `fn ` starts a function item in a trimmed line.
fn find_fn(t: &str) -> Option<usize> {
    let t2 = t
        .trim_start_matches("pub ")
        .trim_start_matches("pub(crate) ")
        .trim_start_matches("pub(super) ");
    let prefix = t.len() - t2.len();
    let mut s = t2;
    for kw in ["const ", "async ", "unsafe ", "extern \"C\" "] {
        s = s.trim_start_matches(kw);
    }
    s.starts_with("fn ").then(|| prefix + (t2.len() - s.len()))
}

/// The line of the brace that closes the first block opened at or after
/// line `start`, or `None` when a `;` ends the item first (a declaration).
fn block_end(lines: &[&str], start: usize) -> Option<usize> {
    let mut depth = 0i64;
    let mut opened = false;
    let mut parens = 0i64;
    for (i, line) in lines.iter().enumerate().skip(start) {
        for c in line.chars() {
            match c {
                '(' | '[' => parens += 1,
                ')' | ']' => parens -= 1,
                ';' if !opened && parens == 0 => return None,
                '{' => {
                    depth += 1;
                    opened = true;
                }
                '}' => {
                    depth -= 1;
                    if opened && depth == 0 {
                        return Some(i);
                    }
                }
                _ => {}
            }
        }
    }
    None
}

/// The source with the contents of comments, strings and character
/// literals blanked (newlines kept).
fn blank_literals(src: &str) -> String {
    let c: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    let blank = |ch: char| if ch == '\n' { '\n' } else { ' ' };
    while i < c.len() {
        match c[i] {
            '/' if c.get(i + 1) == Some(&'/') => {
                while i < c.len() && c[i] != '\n' {
                    out.push(' ');
                    i += 1;
                }
            }
            '/' if c.get(i + 1) == Some(&'*') => {
                let mut depth = 0;
                while i < c.len() {
                    if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                        depth += 1;
                        out.push_str("  ");
                        i += 2;
                    } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                        depth -= 1;
                        out.push_str("  ");
                        i += 2;
                        if depth == 0 {
                            break;
                        }
                    } else {
                        out.push(blank(c[i]));
                        i += 1;
                    }
                }
            }
            'r' if matches!(c.get(i + 1), Some('"' | '#'))
                && !c
                    .get(i.wrapping_sub(1))
                    .is_some_and(|p| p.is_alphanumeric() || *p == '_') =>
            {
                let mut j = i + 1;
                let mut hashes = 0;
                while c.get(j) == Some(&'#') {
                    hashes += 1;
                    j += 1;
                }
                if c.get(j) != Some(&'"') {
                    out.push(c[i]);
                    i += 1;
                    continue;
                }
                out.extend(std::iter::repeat_n(' ', j + 1 - i));
                i = j + 1;
                while i < c.len() {
                    if c[i] == '"' && (0..hashes).all(|k| c.get(i + 1 + k) == Some(&'#')) {
                        out.extend(std::iter::repeat_n(' ', hashes + 1));
                        i += hashes + 1;
                        break;
                    }
                    out.push(blank(c[i]));
                    i += 1;
                }
            }
            '"' => {
                out.push(' ');
                i += 1;
                while i < c.len() && c[i] != '"' {
                    if c[i] == '\\' {
                        out.push(' ');
                        i += 1;
                    }
                    if i < c.len() {
                        out.push(blank(c[i]));
                        i += 1;
                    }
                }
                out.push(' ');
                i += 1;
            }
            '\'' => {
                // A character literal ('x', '\n', '\u{..}'), or a lifetime.
                let end = if c.get(i + 1) == Some(&'\\') {
                    (i + 2..c.len().min(i + 12)).find(|&j| c[j] == '\'')
                } else {
                    (c.get(i + 2) == Some(&'\'')).then_some(i + 2)
                };
                match end {
                    Some(e) => {
                        out.extend(std::iter::repeat_n(' ', e + 1 - i));
                        i = e + 1;
                    }
                    None => {
                        out.push('\'');
                        i += 1;
                    }
                }
            }
            ch => {
                out.push(ch);
                i += 1;
            }
        }
    }
    out
}

// ---- the tests ----

#[test]
fn file_names_are_plain() {
    let files = tracked();
    let odd = odd_names(files.iter().map(String::as_str));
    assert!(odd.is_empty(), "tracked files with odd names: {odd:?}");
}

#[test]
fn links_in_the_docs_resolve() {
    let files: BTreeSet<String> = tracked().into_iter().collect();
    let exists =
        |p: &str| files.contains(p) || files.iter().any(|f| f.starts_with(&format!("{p}/")));
    let mut broken = Vec::new();
    for page in files.iter().filter(|f| f.ends_with(".md")) {
        let md = text_of(page).unwrap();
        broken.extend(broken_links(page, &md, &exists, &text_of));
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn paths_in_comments_exist() {
    let files: BTreeSet<String> = tracked().into_iter().collect();
    let tops: BTreeSet<String> = files
        .iter()
        .filter_map(|f| f.split_once('/').map(|(top, _)| top.to_string()))
        .chain(files.iter().filter_map(|f| {
            // A crate's own top-level folders (`src`, `benches`, …).
            let parts: Vec<&str> = f.split('/').collect();
            (parts.len() > 3 && parts[0] == "crates").then(|| parts[..3].join("/"))
        }))
        .collect();
    let mut dangling = Vec::new();
    for file in files
        .iter()
        .filter(|f| f.ends_with(".rs") || f.ends_with(".js"))
    {
        let src = text_of(file).unwrap();
        let root = crate_root(file);
        for (n, comment) in comments(&src) {
            for p in dangling_paths(comment, &tops, &root, &files) {
                dangling.push(format!("{file}:{n}: {p}"));
            }
        }
    }
    assert!(
        dangling.is_empty(),
        "comments naming paths that do not exist:\n{}",
        dangling.join("\n")
    );
}

#[test]
fn nothing_cites_the_first_contract_or_an_issue() {
    let mut found = Vec::new();
    for file in tracked() {
        let Some(text) = text_of(&file) else { continue };
        for n in citations(&text) {
            found.push(format!("{file}:{n}"));
        }
    }
    assert!(
        found.is_empty(),
        "cite docs/ or the paper instead:\n{}",
        found.join("\n")
    );
}

#[test]
fn functions_read_in_one_sitting() {
    let mut long = Vec::new();
    for file in tracked() {
        let library = (file.starts_with("src/") || file.starts_with("crates/"))
            && file.ends_with(".rs")
            && !file.ends_with("/tests.rs")
            && !file.contains("/tests/");
        if !library {
            continue;
        }
        for (name, n) in long_functions(&text_of(&file).unwrap(), MAX_FN_LINES) {
            long.push((format!("{file}: {name}"), n));
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_FN_LINES} lines (split them along their seams): {long:?}"
    );
}

#[test]
fn each_check_fails_on_a_planted_example() {
    assert_eq!(
        odd_names(["src/lib.rs", "hat-each-loss-does)) |#"]),
        ["hat-each-loss-does)) |#"]
    );

    let page = "# Top\n\n## The `peer` fleet: how\n\nSee [a](b.md), [c](#top), \
                [d](#the-peer-fleet-how), [e](b.md#nowhere), [f](missing.md)\n\
                and ([docs/peer.md](docs/peer.md\n";
    let other = "# Here\n";
    let exists = |p: &str| p == "a.md" || p == "b.md";
    let read = |p: &str| match p {
        "a.md" => Some(page.to_string()),
        "b.md" => Some(other.to_string()),
        _ => None,
    };
    let broken = broken_links("a.md", page, &exists, &read);
    assert_eq!(broken.len(), 3, "{broken:?}");
    assert!(broken[0].contains("b.md#nowhere"), "{broken:?}");
    assert!(broken[1].contains("missing.md"), "{broken:?}");
    assert!(broken[2].contains("never closes"), "{broken:?}");

    let files: BTreeSet<String> = ["src/lib.rs", "crates/engine/src/lib.rs", "docs/api.md"]
        .map(String::from)
        .into();
    let tops: BTreeSet<String> = ["src", "crates", "docs", "crates/engine/src"]
        .map(String::from)
        .into();
    let comment = " see src/lib.rs, docs/api.md#x, src/geometry/geodesy.rs, \
                   https://example.org/src/x and docs/a*.md";
    assert_eq!(
        dangling_paths(comment, &tops, "", &files),
        ["src/geometry/geodesy.rs"]
    );
    assert!(dangling_paths(" src/lib.rs", &tops, "crates/engine", &files).is_empty());

    let cited = format!(
        "a\n// {} 4 says\n// see {} 12\n// an issue of tide 3\n",
        concat!("SP", "EC §"),
        concat!("iss", "ue")
    );
    assert_eq!(citations(&cited), [2, 3]);

    let body = "    let x = \"}\";\n".repeat(MAX_FN_LINES - 1);
    let src = format!(
        "fn short() {{}}\nfn long() {{\n{body}}}\n#[cfg(test)]\nmod tests {{\n    fn t() {{\n{body}    }}\n}}\n"
    );
    assert_eq!(
        long_functions(&src, MAX_FN_LINES),
        [("long".to_string(), MAX_FN_LINES + 1)]
    );
}
